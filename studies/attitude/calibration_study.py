"""The calibration study behind ``imutherm calibrate``: draw a unit, calibrate it on the simulated rig,
evaluate both models on a held-out test set; the ``calibration.json`` content with the paper's figures."""

from __future__ import annotations

import time

import numpy as np

from imutherm import InputError
from imutherm.imu.calibration import calibrate_unit, evaluate_calibration
from imutherm.imu.compensation import INTERPS
from imutherm.imu.sensor_model import G0, draw_unit, unit_to_dict


def _paper() -> dict:
    from imutherm.studies.paper import load_paper

    c = load_paper()["calibration"]
    return {"conventional_max_residual_mg": c["conventional_max_residual_mg"],
            "improved_max_residual_mg": c["improved_max_residual_mg"],
            "source": "Liu et al. 2012 section 2.2.2 (studies/paper_targets.toml [calibration])"}


PAPER = _paper()
_KEYS = {"none": "uncompensated", "conventional": "conventional", "improved": "improved"}


def run_calibration(grade: str = "adis16355", seed: int = 0, *, oven_mount_deg: float | None = None,
                    interp: str = "segment", n_temps: int = 23) -> dict:
    """Draw a unit, calibrate it, evaluate it; return the content of calibration.json (no files written).

    Parameters
    ----------
    grade : str; seed : int (all randomness from numpy.random.default_rng(seed))
    oven_mount_deg : float [°] | None   unknown oven-mounting rotation (None: RigConfig default)
    interp : str                        "segment" | "linear" temperature lookup at compensation
    n_temps : int                       test soak temperatures
    """
    if interp not in INTERPS:
        raise InputError(f"--interp: {interp!r} is not valid; valid: {', '.join(INTERPS)}")
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    unit = draw_unit(grade, rng)
    over = {} if oven_mount_deg is None else {"oven_mount_deg": float(oven_mount_deg)}
    cal = calibrate_unit(unit, rng, **over)
    ev = evaluate_calibration(unit, cal, rng, interp=interp, n_temps=n_temps)
    mg, dps = 1e3 / G0, 180.0 / np.pi
    edges = cal.segment_edges_C
    segments = []
    for k in range(edges.size - 1):
        segments.append({
            "range_C": [float(edges[k]), float(edges[k + 1])],
            "reported_temp_C": cal.segment_nodes_C[k].tolist(),
            "conventional_fit_rms_mg": (cal.accel.conv_fit_rms[k] * mg).tolist(),
            "conventional_fit_rms_dps": (cal.gyro.conv_fit_rms[k] * dps).tolist(),
            "conventional_accel_scale_minus_1": (np.diag(cal.accel.K_conv[k]) - 1.0).tolist(),
            "conventional_accel_bias_mg": (cal.accel.D_conv[k] * mg).tolist(),
            "improved_sigma_fit_rms_mg": (cal.accel.sigma_fit_rms[k] * mg).tolist(),
            "improved_sigma_fit_rms_dps": (cal.gyro.sigma_fit_rms[k] * dps).tolist(),
            "improved_accel_c_mg": (cal.accel.sigma[k, :, 2] * mg).tolist(),
            "improved_accel_b": cal.accel.sigma[k, :, 1].tolist(),
            "improved_gyro_c_dps": (cal.gyro.sigma[k, :, 2] * dps).tolist(),
        })
    acc = {_KEYS[k]: v for k, v in ev.accel_max_residual_mg.items()}
    gyr = {_KEYS[k]: v for k, v in ev.gyro_max_residual_dps.items()}
    return {
        "grade": unit.grade.name,
        "seed": int(seed),
        "interp": interp,
        "oven_mount_deg": cal.meta.rig.oven_mount_deg,
        "accel_max_residual_mg": acc,
        "gyro_max_residual_dps": gyr,
        "ratio_conventional_over_improved": {"accel": acc["conventional"] / acc["improved"],
                                             "gyro": gyr["conventional"] / gyr["improved"]},
        "paper": PAPER,
        "test_set": {"n_temps": n_temps, "runs": int(ev.temp_C.size),
                     "description": "new power-on; random soak temperatures over the calibrated range, random "
                                    "static orientations and random-axis rates 10..300 deg/s; none used in the fits"},
        "room_temperature": {"accel_K": cal.accel.K_room.tolist(), "accel_bias_mg": (cal.accel.D_room * mg).tolist(),
                             "gyro_K": cal.gyro.K_room.tolist(), "gyro_bias_dps": (cal.gyro.D_room * dps).tolist(),
                             "accel_fit_rms_mg": (cal.accel.room_fit_rms * mg).tolist(),
                             "gyro_fit_rms_dps": (cal.gyro.room_fit_rms * dps).tolist()},
        "segments": segments,
        "evaluation": {"temp_C": ev.temp_C.tolist(), "is_rate": ev.is_rate.tolist(),
                       "accel_residual_mg": {k: v.tolist() for k, v in ev.accel_residual_mg.items()},
                       "gyro_residual_dps": {k: v.tolist() for k, v in ev.gyro_residual_dps.items()}},
        "calibration": cal.to_dict(),
        "unit": unit_to_dict(unit),
        "runtime_s": time.perf_counter() - t0,
    }
