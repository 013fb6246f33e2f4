"""
The IMU chain through the API: sensor model, calibration, compensation, attitude filters
========================================================================================

What ``imutherm compare`` does with each scheme's sensor-die temperatures, as library calls, one stage each:
a unit of the sensor grade is drawn from a seed (its true biases, scale factors, misalignments and their
temperature curves), calibrated in a simulated oven, flown along a trajectory while its dies warm up, its
outputs compensated, and the attitude filters run on them; the roll and pitch errors are the answer.

The temperature curve here is an input: each die rises to its steady value with a first-order lag,
``T(t) = 70 °C + ΔT (1 − exp(−t/τ))``, with the rises ΔT and the times τ = t63 of the reference unit's grease
scheme (default mesh, as ``imutherm compare`` gave them on 2026-12-04: ``summary.json``,
``schemes.grease.sites``). The model's own curves are a transient solve's probe history (the thermal API
example) or a site-temperature table read with :func:`imutherm.site_table.read_site_table`.
"""

# %%
# One unit, two calibrations
# --------------------------
# The unit calibrated bare (the sensors alone, the dies at the chamber's temperature over −40..70 °C) and
# calibrated assembled and powered, its dies above the chamber by their self-heating (here the steady rise
# at every chamber temperature; the study solves it at −40 and 70 °C, where it differs by a few kelvin).
# Each seed feeds its own stream: the unit, the calibration rig, the flight.
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.imu.calibration import calibrate_unit
from imutherm.imu.compensation import compensate, out_of_range_mask
from imutherm.imu.filters.run import run_filters
from imutherm.imu.motion import DEFAULT_LEVER_ARM, make_profile
from imutherm.imu.sensor_model import G0, SITES, draw_unit, simulate_imu
from imutherm.studies.attitude.filter_settings import load_settings

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "api_imu"
OUT.mkdir(parents=True, exist_ok=True)
AMBIENT_C = 70.0
RISE_K = np.array([7.93, 8.15, 9.33, 10.93, 9.54, 7.07])       # SITES order: gyro_x..z, accel_x..z
T63_S = np.array([149.0, 127.0, 117.0, 89.0, 111.0, 158.0])
unit_seed, rig_seed, flight_seed = np.random.SeedSequence(0).spawn(3)

unit = draw_unit("adis16355", np.random.default_rng(unit_seed))
calibrations = {
    "bare": calibrate_unit(unit, np.random.default_rng(rig_seed)),
    "unit": calibrate_unit(unit, np.random.default_rng(rig_seed), self_heating=lambda chamber_C: RISE_K),
}
for name, cal in calibrations.items():
    print(f"calibrated {name}: reported temperatures up to "
          + ", ".join(f"{s} {T:.1f}" for s, T in zip(SITES, cal.site_range_C()[1])) + " °C")

# %%
# The flight, with the dies warming up
# ------------------------------------
# The ``flight`` profile (400 s: take-off, climbs, turns, descent) at the grade's sample rate, the sensor at
# its lever arm from the centre of rotation; :func:`~imutherm.imu.sensor_model.simulate_imu` gives the raw
# gyro [rad/s] and accelerometer [m/s²] samples and the temperatures the sensors report (lagged, offset).
rate = unit.grade.sample_rate_hz
lever_arm = DEFAULT_LEVER_ARM["flight"]
flight = make_profile("flight", rate_hz=rate, lever_arm=lever_arm)
die_C = AMBIENT_C + RISE_K * (1.0 - np.exp(-flight.t[:, None] / T63_S))
raw = simulate_imu(unit, flight.t, flight.omega_b, flight.f_b, die_C, np.random.default_rng(flight_seed))
for name, cal in calibrations.items():
    print(f"beyond the {name} calibration's range: {100 * out_of_range_mask(raw.temp_C, cal).mean():.1f} % "
          "of the sensor samples")

# %%
# Compensation and the filters
# ----------------------------
# Each calibration compensates the raw samples (``conventional``: the segment-wise fit of the oven data;
# ``improved``: the room-temperature fit plus a per-segment correction; beyond the calibrated range the
# temperature trend is extended, ``out_of_range="linear"``, as the study does), and the filters run on the
# result at their tuned settings for the profile. The residual accelerometer error is averaged over 5 s
# windows, as the study reports it.
FILTERS = ("gated", "kf", "aekf")
settings = load_settings().for_profile("flight", FILTERS)
rows, residual = [], {}
window = int(5 * rate)
for cal_name, cal in calibrations.items():
    for method in ("none", "conventional", "improved"):
        samples = compensate(raw, cal, method, out_of_range="linear")
        estimates, _ = run_filters(samples.gyro, samples.accel, 1.0 / rate, lever_arm, names=FILTERS,
                                   settings=settings)
        err_mg = 1e3 * (samples.accel - flight.f_b) / G0
        n = err_mg.shape[0] // window * window
        residual[cal_name, method] = err_mg[:n].reshape(-1, window, 3).mean(axis=1)
        rms = {f: [np.degrees(np.sqrt(np.mean(np.angle(np.exp(1j * (a - b))) ** 2)))
                   for a, b in ((e.roll, flight.roll), (e.pitch, flight.pitch))] for f, e in estimates.items()}
        rows.append((cal_name, method, np.sqrt(np.mean(residual[cal_name, method] ** 2)), rms))

print("calibration compensation  accel [mg RMS]  roll/pitch RMS [deg]: " + ", ".join(FILTERS))
for cal_name, method, accel_rms, rms in rows:
    print(f"{cal_name:11s} {method:12s} {accel_rms:15.2f}  "
          + "  ".join(f"{f} {rms[f][0]:.2f}/{rms[f][1]:.2f}" for f in FILTERS))

# %%
# What the warm-up leaves in the accelerometers
# ---------------------------------------------
# Left: the dies' temperatures (true, and as reported) against each calibration's upper end. Right: the
# residual error of the x accelerometer (5 s means) after the improved compensation with each calibration.
fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
a.plot(flight.t, die_C[:, 3], label="accel_x die, true")
a.plot(flight.t, raw.temp_C[:, 3], label="accel_x, reported")
for name, style in (("bare", ":"), ("unit", "--")):
    a.axhline(calibrations[name].site_range_C()[1][3], color="k", ls=style, label=f"{name} calibration's top")
a.set(xlabel="time [s]", ylabel="temperature [°C]", title="the warm-up against the calibrated range")
a.legend(fontsize=8)
t_win = np.arange(residual["unit", "improved"].shape[0]) * 5.0 + 2.5
for name in calibrations:
    b.plot(t_win, residual[name, "improved"][:, 0], label=f"calibrated {name}")
b.set(xlabel="time [s]", ylabel="accel_x residual [mg]", title="improved compensation, 5 s means")
b.grid(alpha=0.3)
b.legend(fontsize=8)
plt.show()
