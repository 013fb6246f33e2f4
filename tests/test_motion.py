"""Motion profiles: closed forms (coordinated turn, swing) and kinematic consistency."""

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu import motion
from imutherm.imu.attitude_math import G0, euler_to_quat, quat_to_dcm, quat_to_euler


def _qmul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], -1)


@pytest.fixture(scope="module")
def flight():
    return motion.flight_profile(400.0, 200.0)


def test_euler_quat_roundtrip():
    r, p, y = np.radians([10.0, -35.0, 170.0])
    rr, pp, yy = quat_to_euler(euler_to_quat(r, p, y))
    assert np.allclose([rr, pp, yy], [r, p, y], atol=1e-12)


def test_coordinated_turn_closed_form(flight):
    # steady part of the first standard-rate turn: level, V = 60 m/s, psi_dot = 3 deg/s
    seg = flight.segment == "turn-1"
    t = flight.t[seg]
    mid = seg & (flight.t > t[0] + 6.0) & (flight.t < t[-1] - 6.0)
    V, w = 60.0, np.radians(3.0)
    phi = np.arctan(V * w / G0)  # tan(phi) = V omega / g
    assert np.allclose(flight.roll[mid], phi, atol=1e-12)
    assert np.allclose(flight.pitch[mid], 0.0, atol=1e-12)
    f_expected = np.array([0.0, 0.0, -G0 / np.cos(phi)])
    assert np.allclose(flight.f_b[mid], f_expected, atol=1e-9)
    om_expected = w * np.array([0.0, np.sin(phi), np.cos(phi)])
    assert np.allclose(flight.omega_b[mid], om_expected, atol=1e-12)
    assert np.allclose(flight.omega_dot_b[mid], 0.0, atol=1e-12)


def test_flight_is_coordinated_everywhere(flight):
    assert np.max(np.abs(flight.f_b[:, 1])) < 1e-9  # zero lateral specific force, lever arm 0


def test_swing_closed_form():
    d = np.array([0.0, 0.03, 0.05])
    tr = motion.swing_profile(60.0, 200.0, lever_arm=d)
    A, rate = np.radians(80.0), np.radians(200.0)
    W = rate / A
    m = (tr.t > 16.0) & (tr.t < 44.0)  # full amplitude (envelopes over 10..15 s and 45..50 s)
    ph = W * (tr.t[m] - 10.0)
    assert np.allclose(tr.roll[m], A * np.sin(ph), atol=1e-12)
    assert np.allclose(tr.omega_b[m, 0], A * W * np.cos(ph), atol=1e-12)
    assert np.allclose(tr.omega_dot_b[m, 0], -A * W**2 * np.sin(ph), atol=1e-12)
    assert np.allclose(tr.omega_b[m, 1:], 0.0) and np.allclose(tr.omega_dot_b[m, 1:], 0.0)
    assert np.degrees(np.max(np.abs(tr.omega_b[:, 0]))) == pytest.approx(200.0, rel=1e-4)
    assert np.degrees(np.max(np.abs(tr.roll))) == pytest.approx(80.0, rel=1e-4)
    # specific force with the lever arm: gravity + tangential + centripetal (rotation about x)
    phi, p, pd = tr.roll[m], tr.omega_b[m, 0], tr.omega_dot_b[m, 0]
    fx = np.zeros_like(phi)
    fy = -G0 * np.sin(phi) - pd * d[2] - p**2 * d[1]
    fz = -G0 * np.cos(phi) + pd * d[1] - p**2 * d[2]
    assert np.allclose(tr.f_b[m], np.column_stack([fx, fy, fz]), atol=1e-9)


@pytest.mark.parametrize("name", ["flight", "swing", "shake"])
def test_rate_and_force_consistent_with_attitude_and_velocity(name):
    rate = 400.0
    d = (0.3, -0.1, 0.05)
    tr = motion.make_profile(name, 120.0 if name != "flight" else 200.0, rate, lever_arm=d)
    dt = 1.0 / rate
    q = tr.quat
    qd = (q[2:] - q[:-2]) / (2 * dt)
    w_num = 2 * _qmul(q[1:-1] * [1, -1, -1, -1], qd)[:, 1:]
    scale = max(1.0, np.max(np.abs(tr.omega_b)))
    assert np.max(np.abs(w_num - tr.omega_b[1:-1])) < 1e-4 * scale
    wd_num = (tr.omega_b[2:] - tr.omega_b[:-2]) / (2 * dt)
    assert np.max(np.abs(wd_num - tr.omega_dot_b[1:-1])) < 1e-3 * max(1.0, np.max(np.abs(tr.omega_dot_b)))
    # specific force at the CG from the velocity history, then the lever-arm terms
    a_n = (tr.vel_n[2:] - tr.vel_n[:-2]) / (2 * dt)
    C = quat_to_dcm(q[1:-1])
    f_cg = np.einsum("nji,nj->ni", C, a_n - [0.0, 0.0, G0])
    w, wd = tr.omega_b[1:-1], tr.omega_dot_b[1:-1]
    f = f_cg + np.cross(wd, d) + np.cross(w, np.cross(w, d))
    assert np.max(np.abs(f - tr.f_b[1:-1])) < 2e-3 * max(1.0, np.max(np.abs(a_n)))


def test_static_profile():
    tr = motion.static_profile(5.0, 100.0)
    assert np.allclose(tr.f_b, [0.0, 0.0, -G0]) and np.allclose(tr.omega_b, 0.0)
    assert set(tr.phase) == {"stable"}


def test_shake_exceeds_one_g_and_keeps_attitude():
    tr = motion.shake_profile(60.0, 100.0)
    horiz = np.hypot(tr.f_b[:, 0], tr.f_b[:, 1])
    assert horiz.max() > G0
    assert np.allclose(tr.roll, 0.0) and np.allclose(tr.pitch, 0.0)
    assert np.all(horiz[tr.phase == "stable"][: int(9.0 * 100)] < 1e-12)


def test_flight_segments_and_durations(flight):
    names = set(np.char.rstrip(np.char.rstrip(flight.segment.astype(str), "0123456789"), "-"))
    for n in ("ground", "takeoff", "climb", "turn", "pitch", "circle", "level", "landing"):
        assert n in names
    assert set(flight.phase) == {"stable", "manoeuvre"}
    assert np.all(flight.phase[flight.segment == "circle-1"] == "manoeuvre")
    assert np.all(flight.phase[flight.segment == "level-1"] == "stable")
    for dur in (60.0, 400.0, 3600.0):
        assert sum(s[2] for s in motion.flight_plan(dur)) == pytest.approx(dur)
    # speed returns to zero, at rest at the end
    assert np.linalg.norm(flight.vel_n[-1]) < 1e-9 and np.linalg.norm(flight.vel_n, axis=1).max() == pytest.approx(60.0)


def test_bad_input():
    with pytest.raises(InputError, match="profile='loop' is unknown; valid: static, swing, shake, flight"):
        motion.make_profile("loop")
    with pytest.raises(InputError, match="duration"):
        motion.flight_profile(10.0)
    with pytest.raises(InputError, match="lever_arm"):
        motion.static_profile(5.0, lever_arm=(1.0, 2.0))
    with pytest.raises(InputError, match="axis"):
        motion.swing_profile(60.0, axis="q")


def test_vehicle_turn_rolls_outward_by_the_roll_gradient():
    tr = motion.vehicle_profile(240.0, 100.0)
    seg = np.flatnonzero(tr.segment == "turn-1")
    k = seg[len(seg) // 2]  # middle of the steady part of the 90° turn at 14 m/s, 12 °/s
    a_y = 14.0 * np.radians(12.0)
    assert np.degrees(tr.roll[k]) == pytest.approx(-5.0 * a_y / G0, rel=1e-6)  # outward: left in a right turn
    # not coordinated: the lateral specific force is the centripetal acceleration seen in the rolled body
    assert tr.f_b[k, 1] == pytest.approx(a_y * np.cos(tr.roll[k]) - G0 * np.sin(tr.roll[k]), rel=1e-6)
    assert abs(np.linalg.norm(tr.vel_n[-1])) < 1e-6 and np.all(tr.phase[-100:] == "stable")
    assert np.allclose(tr.f_b[-100:], [0.0, 0.0, -G0], atol=1e-9)


@pytest.mark.parametrize("name", ["vehicle", "handheld"])
def test_new_profiles_are_kinematically_consistent(name):
    tr = motion.make_profile(name, None, 200.0)
    q = tr.quat
    qd = np.gradient(q, tr.t, axis=0)
    om = 2 * _qmul(q * np.array([1, -1, -1, -1]), qd)[:, 1:]
    assert np.max(np.abs(om - tr.omega_b)[2:-2]) < 2e-3 * max(1.0, np.max(np.abs(tr.omega_b)))
    assert tr.phase[0] == "stable" and np.sum(tr.segment == tr.segment[0]) / 200.0 >= 10.0  # leveling rest
    if name == "handheld":
        assert np.degrees(np.max(np.abs(tr.omega_b))) > 150.0  # the flicks
        walk = np.char.startswith(tr.segment.astype(str), "walk")
        assert np.std(np.linalg.norm(tr.f_b[walk], axis=1)) > 1.0  # step accelerations
