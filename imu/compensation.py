"""Run-time compensation of raw IMU samples with a :class:`~imutherm.imu.calibration.Calibration`.

Methods
-------
``none``          raw samples returned unchanged.
``conventional``  Liu et al. 2012 eq. 1 per temperature segment: ``N = K_s E + D_s`` ->
                  ``E = K_s^-1 (N - D_s)``. Row i of ``K_s`` and ``D_s`` (sensor i)
                  is taken from the segment of sensor i's own reported temperature.
``improved``      Liu et al. 2012 eq. 2-3: ``N - sigma_s(N) = K_room E + D_room`` with
                  ``sigma_s,i = a N_i^2 + b N_i + c`` per axis and segment ->
                  ``E = K_room^-1 (N - sigma - D_room)``.

Temperature lookup (``interp``): ``"segment"`` (default, as in Liu et al. 2012: each
5 °C segment has its own parameter group; the segment is found from the
*reported* temperature) or ``"linear"`` (parameters interpolated linearly
between the temperatures at which the segments were calibrated, extrapolated
linearly in the half segments beyond the end nodes).

Out-of-range policy (``out_of_range``): each site's calibrated range is the
span of *its own reported temperature* during the calibration
(:meth:`Calibration.site_edges`: a unit calibrated assembled, in an oven, has
its sensors' self-heating in it). A reported temperature outside it is

* ``"error"`` (default): refused with :class:`imutherm.InputError`;
* ``"hold"``: clamped to the range (the end segment's parameters, evaluated at
  the range end: the compensation stops following the temperature);
* ``"linear"``: the parameters extrapolated linearly in temperature from the
  two outermost calibration nodes (the trend of the last 5 °C carried on).

:func:`out_of_range_mask` flags the samples a policy had to act on, so every
result can say how much of it was extrapolated.

Room-temperature node of the improved model: sigma is defined relative to the
room-temperature (25 °C) calibration, so it is zero there (Liu et al. 2012: "the
coefficients are zero at room temperature"). The fitted segments do not
contain that point (their nodes are the segment centres, 22.5 and 27.5 °C
next to it, and the room temperature is a segment *edge*), so the improved
lookup adds the room-temperature reference, at each site's reported
temperature ``Calibration.room_temp_C`` (25 °C plus that sensor's offset), as
a node with sigma = 0: in ``"segment"`` mode a reported temperature equal to
it (within ``ROOM_NODE_TOL_C``) gets sigma = 0, i.e. exactly the room-temperature
calibration; in ``"linear"`` mode sigma is interpolated through it. The
conventional model has no such node (its K_s, D_s are absolute, not relative
to 25 °C).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from imutherm import InputError
from imutherm.imu.sensor_model import SITES, ImuSamples, validate_samples

if TYPE_CHECKING:  # pragma: no cover
    from imutherm.imu.calibration import Calibration

METHODS = ("none", "conventional", "improved")
INTERPS = ("segment", "linear")
OUT_OF_RANGE = ("error", "hold", "linear")
#: [°C] a reported temperature this close to the room-temperature reference is "at" it (segment mode):
#: the same reading of the internal sensor, up to floating-point rounding of the calibration's mean
ROOM_NODE_TOL_C = 1e-6


def _params_at(params: np.ndarray, nodes: np.ndarray, edges: np.ndarray, T: np.ndarray, interp: str,
               zero_at: np.ndarray | None = None) -> np.ndarray:
    """Per-sample, per-axis parameters.

    params (S,3,P), nodes (S,3) [°C], edges (S+1,3) [°C] per axis, T (N,3) [°C] -> (N,3,P).
    zero_at (3,) [°C] | None: an extra node per axis at which the parameters are zero (the improved model's
    room-temperature reference): "segment" gives zero there (|T - zero_at| <= ROOM_NODE_TOL_C), "linear"
    interpolates through it.
    """
    S = params.shape[0]
    axes = np.arange(3)[None, :]
    if interp == "segment" or (S == 1 and zero_at is None):
        k = np.column_stack([np.searchsorted(edges[:, i], T[:, i], side="right") - 1 for i in range(3)])
        k = np.clip(k, 0, S - 1)  # (N,3)
        out = params[k, axes]
        if zero_at is not None:
            out = np.where((np.abs(T - np.asarray(zero_at, float)[None, :]) <= ROOM_NODE_TOL_C)[:, :, None],
                           0.0, out)
        return out
    out = np.empty(T.shape + (params.shape[2],))
    for i in range(3):
        n, p = nodes[:, i], params[:, i]
        if zero_at is not None:
            z = float(zero_at[i])
            keep = np.abs(n - z) > ROOM_NODE_TOL_C  # a fitted node on the room node would duplicate it
            n, p = n[keep], p[keep]
            j0 = np.searchsorted(n, z)
            n = np.insert(n, j0, z)
            p = np.insert(p, j0, np.zeros(p.shape[1]), axis=0)
        j = np.clip(np.searchsorted(n, T[:, i]), 1, n.size - 1)
        w = ((T[:, i] - n[j - 1]) / (n[j] - n[j - 1]))[:, None]  # linear extrapolation beyond end nodes
        out[:, i] = (1.0 - w) * p[j - 1] + w * p[j]
    return out


def out_of_range_mask(temp_C, calibration: "Calibration") -> np.ndarray:
    """(N,6) bool: reported temperature [°C] (N,6) outside each site's calibrated range (SITES order)."""
    e = calibration.site_edges()
    temp = np.asarray(temp_C, float)
    return (temp < e[0][None, :]) | (temp > e[-1][None, :])


def _check_range(temp: np.ndarray, edges: np.ndarray) -> None:
    bad = (temp < edges[0][None, :]) | (temp > edges[-1][None, :])
    if np.any(bad):
        n, j = np.argwhere(bad)[0]
        lo, hi = edges[0, j], edges[-1, j]
        raise InputError(
            f"samples.temp_C[{n}, {j}] ({SITES[j]}): reported temperature {temp[n, j]:.2f} °C is outside the "
            f"calibrated range; valid: {lo:.4g}..{hi:.4g} °C ({int(bad.sum())} samples out of range; "
            "out_of_range='hold' or 'linear' compensates them anyway)")


def compensate(samples: ImuSamples, calibration: "Calibration | None", method: str, *,
               interp: str = "segment", out_of_range: str = "error") -> ImuSamples:
    """Compensate raw samples with a calibration.

    Parameters
    ----------
    samples : ImuSamples         raw outputs: gyro [rad/s] (N,3), accel [m/s^2] (N,3), reported temp_C [°C] (N,6)
    calibration : Calibration | None   required unless method == "none"
    method : str                 "none" | "conventional" | "improved"
    interp : str                 "segment" (lookup by reported temperature) | "linear"
    out_of_range : str           "error" | "hold" | "linear" (module docstring); flag the samples it acted
                                 on with :func:`out_of_range_mask`

    Returns
    -------
    ImuSamples  compensated gyro [rad/s] and accel [m/s^2]; t and temp_C unchanged.

    Raises
    ------
    InputError  unknown method / interp / policy, missing calibration, bad shapes, or (policy
                "error") a reported temperature outside the calibrated range.

    Examples
    --------
    A unit calibrated in the oven, then ten seconds level and at rest with its dies at 60 °C: the
    accelerometer error [mg] raw and with each compensation. The conventional fit carries the oven mounting's
    unknown rotation (1.4° by default: g θ ≈ 24 mg, the source paper's argument for the improved fit).

    >>> import numpy as np
    >>> from imutherm.imu.calibration import calibrate_unit
    >>> from imutherm.imu.compensation import compensate
    >>> from imutherm.imu.sensor_model import G0, draw_unit, simulate_imu
    >>> rng = np.random.default_rng(0)
    >>> unit = draw_unit("adis16355", rng)
    >>> calibration = calibrate_unit(unit, np.random.default_rng(1))
    >>> t = np.arange(0.0, 10.0, 0.01)
    >>> f_b = np.tile([0.0, 0.0, -G0], (t.size, 1))
    >>> raw = simulate_imu(unit, t, np.zeros((t.size, 3)), f_b, np.full((t.size, 6), 60.0), rng)
    >>> for method in ("none", "conventional", "improved"):
    ...     samples = compensate(raw, calibration, method)
    ...     print(method, (1e3 * (samples.accel.mean(axis=0) - f_b[0]) / G0).round(1).tolist())
    none [-13.6, 9.9, -36.9]
    conventional [14.0, 19.0, -0.6]
    improved [0.7, -0.4, -1.5]
    """
    if method not in METHODS:
        raise InputError(f"compensation method: {method!r} is not valid; valid: {', '.join(METHODS)}")
    if interp not in INTERPS:
        raise InputError(f"compensation interp: {interp!r} is not valid; valid: {', '.join(INTERPS)}")
    if out_of_range not in OUT_OF_RANGE:
        raise InputError(f"compensation out_of_range: {out_of_range!r} is not valid; "
                         f"valid: {', '.join(OUT_OF_RANGE)}")
    validate_samples(samples)
    if method == "none":
        return samples
    if calibration is None:
        raise InputError(f"calibration: required for method {method!r} (only 'none' works without one)")
    temp = np.asarray(samples.temp_C, float)
    edges = calibration.site_edges()  # (S+1, 6)
    if out_of_range == "error":
        _check_range(temp, edges)
    elif out_of_range == "hold":
        temp = np.clip(temp, edges[0][None, :], edges[-1][None, :])
    outside = out_of_range_mask(temp, calibration) if out_of_range == "linear" else None
    nodes = np.asarray(calibration.segment_nodes_C, float)
    out = {}
    for name, cols in (("gyro", slice(0, 3)), ("accel", slice(3, 6))):
        N = np.asarray(getattr(samples, name), float)
        T = temp[:, cols]
        c = getattr(calibration, name)
        room = np.asarray(calibration.room_temp_C, float)[cols]  # sigma = 0 node (module docstring)

        def params(table, zero_at=None):
            p = _params_at(table, nodes[:, cols], edges[:, cols], T, interp, zero_at=zero_at)
            if outside is not None and interp == "segment" and np.any(outside[:, cols]):
                lin = _params_at(table, nodes[:, cols], edges[:, cols], T, "linear", zero_at=zero_at)
                p = np.where(outside[:, cols, None], lin, p)
            return p

        if method == "conventional":
            KD = np.concatenate([c.K_conv, c.D_conv[:, :, None]], axis=2)  # (S,3,4): row i = [K_i, D_i]
            p = params(KD)  # (N,3,4)
            K, D = p[:, :, :3], p[:, :, 3]
            out[name] = np.linalg.solve(K, (N - D)[:, :, None])[:, :, 0]
        else:
            p = params(c.sigma, zero_at=room)  # (N,3,3): a, b, c
            sig = p[:, :, 0] * N**2 + p[:, :, 1] * N + p[:, :, 2]
            out[name] = np.linalg.solve(c.K_room, (N - sig - c.D_room).T).T
    return ImuSamples(t=samples.t, gyro=out["gyro"], accel=out["accel"], temp_C=samples.temp_C)
