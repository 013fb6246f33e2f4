"""Peer filters (VQF, ahrs Madgwick / Mahony / EKF): our fast equivalents agree with the package, frames are
right, and the tuning procedure's training / held-out split."""

import numpy as np
import pytest
from ahrs.filters import EKF, Madgwick, Mahony

from imutherm import InputError
from imutherm.imu import motion
from imutherm.imu.filters import EKFParams, MadgwickParams, MahonyParams, VQFParams
from imutherm.imu.filters.peers import ekf_batch, madgwick_loop, mahony_loop
from imutherm.imu.filters.registry import filter_names
from imutherm.studies.attitude import filter_benchmark as fb
from imutherm.studies.attitude.attitude_study import run_filters


@pytest.fixture(scope="module")
def noisy():
    rng = np.random.default_rng(0)
    n = 800
    g = rng.normal(0, 0.3, (n, 3))
    a = np.array([0.5, -1.0, 9.7]) + rng.normal(0, 1.0, (n, 3))
    q0 = np.array([0.9, 0.1, -0.2, 0.3])
    return g, a, q0 / np.linalg.norm(q0)


def test_madgwick_agrees_with_ahrs(noisy):
    g, a, q0 = noisy
    ref = Madgwick(gyr=g, acc=a, frequency=100.0, gain=0.1, q0=q0).Q
    assert np.max(np.abs(madgwick_loop(g, a, 0.01, 0.1, q0) - ref)) < 1e-9


def test_mahony_agrees_with_ahrs(noisy):
    g, a, q0 = noisy
    ref = Mahony(gyr=g, acc=a, frequency=100.0, k_P=0.7, k_I=0.2, q0=q0).Q
    assert np.max(np.abs(mahony_loop(g, a, 0.01, 0.7, 0.2, q0) - ref)) < 1e-9


def test_ekf_agrees_with_ahrs(noisy):
    g, a, q0 = noisy
    ref = EKF(gyr=g, acc=a, frequency=100.0, q0=q0, noises=[0.01, 0.04, 0.64]).Q
    ours = ekf_batch(np.stack([g, g]), np.stack([a, a]), 0.01, [0.01, 0.09], [0.04, 0.25], np.stack([q0, q0]))
    assert np.max(np.abs(ours[0] - ref)) < 1e-9
    assert np.max(np.abs(ours[1] - ref)) > 1e-4  # the second record really used its own setting


def test_default_settings_are_the_packages():
    import vqf

    assert VQFParams().tauAcc == vqf.VQF(0.01).params["tauAcc"]
    assert VQFParams().biasSigmaMotion == vqf.VQF(0.01).params["biasSigmaMotion"]
    assert MadgwickParams().gain == Madgwick().gain
    m = Mahony()
    assert (MahonyParams().k_P, MahonyParams().k_I) == (m.k_P, m.k_I)
    e = EKF()
    assert (EKFParams().var_gyr, EKFParams().var_acc) == (e.g_noise, e.a_noise)


def test_vqf_bias_sigma_motion_inf_is_the_motion_bias_update_off():
    """The tuning axis's mode value inf runs VQF with motionBiasEstEnabled false (its limit), and from VQF's
    biasClip (2 deg/s) up the result is already that (the reason the axis is bounded there)."""
    import vqf

    from imutherm.imu.attitude_math import gravity_dir_body
    from imutherm.imu.filters.peers import run_vqf

    rng = np.random.default_rng(3)
    g = rng.normal(0, 0.05, (3000, 3)) + np.array([0.004, -0.002, 0.003])  # in motion (> 2 deg/s) throughout
    a = np.array([0.3, -0.2, -9.79]) + rng.normal(0, 0.3, (3000, 3))
    off = run_vqf(g, a, 0.01, VQFParams(biasSigmaMotion=np.inf), init_s=1.0)
    ref = vqf.VQF(0.01, motionBiasEstEnabled=False).updateBatch(np.ascontiguousarray(g - g[:100].mean(axis=0)),
                                                                 np.ascontiguousarray(-a))["quat6D"]
    assert np.max(np.abs(off.gravity - gravity_dir_body(ref))) < 1e-12
    at_clip = run_vqf(g, a, 0.01, VQFParams(biasSigmaMotion=2.0), init_s=1.0)
    default = run_vqf(g, a, 0.01, VQFParams(), init_s=1.0)
    assert np.max(np.abs(at_clip.gravity - off.gravity)) < 1e-6 < np.max(np.abs(default.gravity - off.gravity))


def test_peers_frames_at_a_fixed_tilt():
    """Static 12° roll, -7° pitch, 40° yaw with small noise: every peer reads the tilt within 0.1° RMS (a frame
    or sign error would show as degrees)."""
    tr = motion.static_profile(40.0, 100.0, roll_deg=12.0, pitch_deg=-7.0, yaw_deg=40.0)
    rng = np.random.default_rng(0)
    g = tr.omega_b + rng.normal(0, 0.002, tr.omega_b.shape) + 0.003
    a = tr.f_b + rng.normal(0, 0.02, tr.f_b.shape)
    est, _ = run_filters(g, a, 0.01, (0, 0, 0), names=filter_names(kind="peer"))
    for n, e in est.items():
        assert np.degrees(np.sqrt(np.mean((e.roll[1000:] - tr.roll[1000:]) ** 2))) < 0.1, n
        assert np.degrees(np.sqrt(np.mean((e.pitch[1000:] - tr.pitch[1000:]) ** 2))) < 0.1, n


def test_split_is_disjoint_and_checked():
    fb.check_split()
    with pytest.raises(InputError, match=r"\('flight', 3\)\] are both training and held-out records"):
        fb.check_split(train=(("flight", (3,)),))
    tr = {(p, s) for p, ss in fb.TRAIN for s in ss}
    ho = {(p, s) for p, ss in fb.HELD_OUT for s in ss}
    assert not tr & ho and len({s for _, ss in fb.HELD_OUT for s in ss}) >= 6
    assert {p for p, _ in fb.HELD_OUT} - {p for p, _ in fb.TRAIN}  # at least one profile never trained on


def test_the_benchmark_tunes_by_the_study_s_procedure():
    """bench_attitude's tuning is the study's one procedure on the registry's axes: on a short training record
    its choice is the grid search's own on the same objective, a ladder value, never worse than the defaults,
    deterministic; a filter without axes (aekf_gnss) or unknown is refused."""
    from imutherm.imu.filters.registry import REGISTRY
    from imutherm.studies.attitude import filter_tuning

    recs = [r for r in fb.make_records((("swing", (100,)),))]
    res = fb.tune("madgwick", recs)
    assert res.objective <= res.default_objective
    direct = filter_tuning.search(REGISTRY["madgwick"].tuning, lambda pt: fb.objective("madgwick", pt, recs))
    ax = REGISTRY["madgwick"].tuning[0]
    if res.chosen == "grid":
        assert res.values == direct["values"] and ax.value(ax.rung(res.values["gain"])) == res.values["gain"]
    assert res.grid == direct["grid"]
    again = fb.tune("madgwick", recs)
    assert again.values == res.values
    for bad in ("nope", "aekf_gnss"):
        with pytest.raises(InputError, match="declares no tuning axes"):
            fb.tune(bad, recs)


def test_benchmark_turn_radius_matches_the_platform_defaults():
    from imutherm.studies.attitude.recorded import PLATFORMS
    from imutherm.studies.attitude.attitude_study import DEFAULT_LEVER_ARM

    for prof in ("vehicle", "handheld"):
        assert fb.TURN_RADIUS[prof] == PLATFORMS[prof][1]
    assert DEFAULT_LEVER_ARM["vehicle"] == PLATFORMS["vehicle"][0]
    # the simulated hand motion has a known 8 cm lever arm; a real hand-held log's rotation centre is unknown (it
    # moves between wrist, elbow and shoulder), and a wrong lever-arm correction is worse than none: the
    # recorded-log platform assumes none
    assert DEFAULT_LEVER_ARM["handheld"] == (0.08, 0.0, 0.0) and PLATFORMS["handheld"][0] == (0.0, 0.0, 0.0)
