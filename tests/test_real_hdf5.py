"""Issue 57 item 4: an .hdf5 that is not shaped like BROAD is refused in one line (the file and what is wrong),
by the reader and by ``imutherm attitude --imu-csv`` (exit 2, no traceback, nothing written)."""

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from imutherm import InputError  # noqa: E402
from imutherm.cli.attitude import main  # noqa: E402
from imutherm.imu.reference_log import read_broad_hdf5  # noqa: E402

N = 500


def _write(path, case):
    rng = np.random.default_rng(0)
    data = {"imu_gyr": rng.normal(0, 0.01, (N, 3)), "imu_acc": np.tile([0.0, 0.0, 9.81], (N, 1)),
            "opt_quat": np.tile([1.0, 0.0, 0.0, 0.0], (N, 1)), "movement": np.ones(N, bool)}
    rate = 100.0
    with h5py.File(path, "w") as h:
        for k, v in data.items():
            if case == "group" and k == "imu_gyr":
                h.create_group(k).create_dataset("x", data=v[:, 0])
            elif case == "scalar" and k == "imu_acc":
                h.create_dataset(k, data=9.81)
            elif case == "bytes" and k == "movement":
                h.create_dataset(k, data=np.array([b"yes"] * N))
            elif case == "missing" and k == "opt_quat":
                continue
            elif case == "shape" and k == "imu_gyr":
                h.create_dataset(k, data=v[:, :2])
            else:
                h.create_dataset(k, data=v)
        if case == "text_rate":
            h.attrs["sampling_rate"] = "285.7 Hz"
        elif case == "bytes_rate":
            h.attrs["sampling_rate"] = np.bytes_(b"100")
        elif case == "array_rate":
            h.attrs["sampling_rate"] = np.array([100.0, 200.0])
        elif case == "zero_rate":
            h.attrs["sampling_rate"] = 0.0
        else:
            h.attrs["sampling_rate"] = rate
    return path


CASES = {
    "group": "'imu_gyr' is a group, not a dataset",
    "scalar": "'imu_acc' is a scalar dataset; valid: an array (N, 3)",
    "bytes": "'movement' holds |S3 (text)",
    "missing": "not a BROAD trial (opt_quat missing)",
    "shape": "'imu_gyr' has shape (500, 2); valid: (N, 3)",
    "text_rate": "attribute sampling_rate is text ('285.7 Hz')",
    "bytes_rate": "attribute sampling_rate is text ('100')",
    "array_rate": "attribute sampling_rate is float64 of shape (2,)",
    "zero_rate": "attribute sampling_rate is 0.0; valid: a positive number",
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_not_broad_shaped_refused_in_one_line(case, tmp_path, capsys):
    p = _write(tmp_path / f"{case}.hdf5", case)
    with pytest.raises(InputError) as ei:
        read_broad_hdf5(p)
    msg = str(ei.value)
    assert CASES[case] in msg and str(p) in msg and "\n" not in msg, msg
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and CASES[case] in err[0] and "Traceback" not in err[0], err
    assert not (tmp_path / "o").exists()


def test_not_hdf5_refused(tmp_path):
    p = tmp_path / "text.hdf5"
    p.write_text("time;gyro\n")
    with pytest.raises(InputError, match="cannot be read as HDF5"):
        read_broad_hdf5(p)


def test_a_well_formed_file_still_reads(tmp_path):
    log = read_broad_hdf5(_write(tmp_path / "ok.hdf5", "ok"))
    assert log.gyro.shape == (N, 3) and log.movement.dtype == bool and np.isclose(log.t[1], 0.01)
