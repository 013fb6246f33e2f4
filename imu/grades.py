"""Sensor grades as data: named parameter sets for the IMU truth model.

Each grade is a plain dict in datasheet units (the unit is in the key name:
``_dps`` [°/s], ``_mg`` [mg], ``_ppm`` [1e-6], ``_deg`` [°], ``_C`` [°C],
``_s`` [s], ``_hz`` [Hz], ``_per_Cmin`` [per °C/min], ``_per_g`` [per g]).
:func:`imutherm.imu.sensor_model.load_grade` converts them to SI.

Provenance of every number is given in the comment next to it:

* **[KF]**    the horizontal-attitude KF paper, quoting the ADIS16355.
* **[DS]**    the Analog Devices datasheet of the part, values *recalled* by the
  author (the datasheets could not be retrieved from the reference library
  during this work; treat them as typical-datasheet magnitudes, not quotes).
* **[Liu]**   Liu et al. 2012 qualitative statements (units of one type differ
  strongly, accelerometers repeat worse than gyros over temperature, error vs
  temperature strongly nonlinear). Liu et al. 2012 gives no numbers for these, so a
  value that only follows such a statement is tagged **[ASSUMED]** with
  "ordering per Liu et al." (e.g. the power-on repeatability: accelerometers worse
  than gyros relative to their temperature curve).
* **[ASSUMED]** chosen by us, with the reason in the comment.

The temperature-curve amplitudes (``*_temp_amplitude_*``) are the *peak*
deviation of the unit's smooth temperature curve from its 25 °C value over
-40..70 °C, before calibration (one unit; the unit draw scales it by a random
factor 0.5..1.5). The accelerometer value is set so the uncompensated
over-temperature bias excursion is a few tens of mg, the magnitude Liu et al.'s
figures 2-3 and its "30 mg after conventional calibration" imply; it is
consistent with a bias tempco of ~0.5 mg/°C over a 55-65 °C swing.

White noise is given as the rms of one sample at ``noise_ref_rate_hz``; the
model converts it to a density (rms / sqrt(rate)) so other sample rates scale
correctly.
"""

from __future__ import annotations

from imutherm.constants import STANDARD_GRAVITY

#: Thermal misalignment, an estimate, not a datasheet value: the boards (FR4, in-plane CTE
#: 14-17 ppm/K) are screwed to an aluminium housing (Al 6061, 23.6 ppm/K); the ~7 ppm/K mismatch over the
#: 110 K range is a 0.08 % differential strain, about 30 um over a 40 mm screw pitch. Taken up partly
#: by screw / standoff slip and partly by board warp, a warp of ~15 um at mid-span (a few tenths of the
#: mismatch) tilts the sensor by ~4 w / L = 1.5 mrad = 0.09 deg at the ends of the range. Solder-joint and
#: package strain add axis-to-axis changes of the same order. We take 2.0e-3 deg/K per off-diagonal
#: element (1 sigma): 0.09 deg at 70 degC, 0.13 deg at -40 degC relative to 25 degC. benchmarks/
#: bench_calibration.py sweeps it (0, 1x, 3x).
GRADES: dict[str, dict] = {
    "adis16355": {
        "description": "ADIS16355 tri-axis MEMS IMU (low-cost grade of the horizontal-attitude KF paper)",
        "sources": [
            "the horizontal-attitude KF paper: gyro bias stability 0.015 deg/s, noise 0.6 deg/s; accel bias stability 0.7 mg, noise 3.5 mg",
            "ADIS16350/ADIS16355 datasheet Rev. PrG (Analog Devices, 2007): 14-bit, +-300 deg/s, +-10 g; "
            "tempcos and misalignment recalled, not verified",
            "assumed values marked in imu/grades.py",
        ],
        "sample_rate_hz": 100.0,                # [ASSUMED] attitude-system output rate (DS max 819.2 SPS)
        "temp_sensor_tau_s": 5.0,               # [ASSUMED] die-to-internal-sensor lag, same package
        "temp_sensor_offset_std_C": 0.5,        # [ASSUMED] internal temperature sensor offset (1 sigma)
        "temp_sensor_lsb_C": 0.1453,            # [DS] TEMP_OUT scale 0.1453 degC/LSB
        "gyro": {
            "noise_rms_dps": 0.6,               # [KF] output noise; [DS] ARW ~4.2 deg/sqrt(h) agrees within 15 %
            "noise_ref_rate_hz": 100.0,         # [ASSUMED] the 0.6 deg/s is read as the rms at 100 Hz
            "bias_instability_dps": 0.015,      # [KF] / [DS] in-run bias stability
            "bias_corr_time_s": 100.0,          # [ASSUMED] Gauss-Markov correlation time
            "rate_random_walk_dps_per_rts": 2.0e-4,  # [ASSUMED] small; not in the datasheet
            "lsb_dps": 0.07326,                 # [DS] 14-bit at +-300 deg/s
            "initial_bias_dps": 0.5,            # [ASSUMED] residual bias after factory cal (1 sigma)
            "initial_sf_ppm": 3000.0,           # [ASSUMED] scale-factor error at 25 degC (1 sigma)
            "misalignment_deg": 0.2,            # [DS] axis-to-axis misalignment +-0.2 deg (recalled), per element 1 sigma
            "misalignment_tempco_deg_per_K": 2.0e-3,  # [ESTIMATE] thermal misalignment, see the note above GRADES
            "turn_on_bias_dps": 0.02,           # [ASSUMED] power-on to power-on bias repeatability (1 sigma): 3.3 % of the 0.6 deg/s curve
            "bias_temp_amplitude_dps": 0.6,     # [DS] bias tempco ~0.01 deg/s/degC x ~60 degC swing (recalled)
            "sf_temp_amplitude_ppm": 4000.0,    # [ASSUMED] ~70 ppm/degC x 60 degC
            "power_on_curve_fraction": 0.02,    # [ASSUMED] ordering per Liu et al. (gyros repeat better than accels): 2 % of the curve
            "temp_rate_coeff_dps_per_Cmin": 0.01,  # [ASSUMED] thermal-gradient bias per degC/min (1 sigma)
            "g_sensitivity_dps_per_g": 0.05,    # [DS] linear acceleration effect 0.05 deg/s/g (recalled)
            "roll_coupling_dps": (0.1, 0.05),   # [ASSUMED] Wang et al.'s roll coupling: 1-sigma y/z gyro error at 300 deg/s
                                                # roll rate from the quadratic and the cubic term (~3e-4 of full
                                                # scale, 2-5x the paper's post-calibration RMSE; Wang et al. gives none)
            "roll_coupling_ref_dps": 300.0,     # [DS] full scale +-300 deg/s: the rate the sizes are stated at
            "full_scale_dps": 300.0,            # [DS] measurement range +-300 deg/s (the fusion peer's gyro range)
        },
        "accel": {
            "noise_rms_mg": 3.5,                # [KF] output noise; [DS] VRW ~0.2 m/s/sqrt(h) agrees
            "noise_ref_rate_hz": 100.0,         # [ASSUMED] the 3.5 mg is read as the rms at 100 Hz
            "bias_instability_mg": 0.7,         # [KF] / [DS] in-run bias stability
            "bias_corr_time_s": 100.0,          # [ASSUMED]
            "rate_random_walk_mg_per_rts": 2.0e-3,  # [ASSUMED] small
            "lsb_mg": 2.522,                    # [DS] 14-bit at +-10 g
            "initial_bias_mg": 10.0,            # [ASSUMED] residual bias after factory cal (1 sigma)
            "initial_sf_ppm": 3000.0,           # [ASSUMED]
            "misalignment_deg": 0.2,            # [DS] recalled, per element 1 sigma
            "misalignment_tempco_deg_per_K": 2.0e-3,  # [ESTIMATE] thermal misalignment, see the note above GRADES
            "turn_on_bias_mg": 0.5,             # [ASSUMED] power-on bias repeatability (1 sigma); the ordering of Liu et al. (accels repeat worse) is carried by power_on_curve_fraction
            "bias_temp_amplitude_mg": 30.0,     # [ASSUMED]/[Liu] tens of mg uncompensated (see module doc)
            "sf_temp_amplitude_ppm": 3000.0,    # [ASSUMED]
            "power_on_curve_fraction": 0.05,    # [ASSUMED] ordering per Liu et al. (accels repeat worse than gyros): 5 % of the curve
            "temp_rate_coeff_mg_per_Cmin": 0.3,  # [ASSUMED] thermal-gradient bias per degC/min (1 sigma)
            "asymmetry_ppm": 500.0,             # [ASSUMED] scale-factor asymmetry (Lin et al.'s term), 1 sigma
            "k2_mg_per_g2": 0.3,                # [ASSUMED] quadratic term K2 (Lin et al.), 1 sigma
        },
    },
    "adis16488": {
        "description": "ADIS16488A tactical-grade MEMS IMU",
        "sources": [
            "ADIS16488A datasheet (Analog Devices): gyro in-run bias 5.1 deg/h, ARW 0.26 deg/sqrt(h); "
            "accel in-run bias 0.1 mg, VRW 0.029 m/s/sqrt(h); values recalled, not verified",
            "assumed values marked in imu/grades.py",
        ],
        "sample_rate_hz": 100.0,                # [ASSUMED] decimated from 2460 SPS
        "temp_sensor_tau_s": 5.0,               # [ASSUMED]
        "temp_sensor_offset_std_C": 0.3,        # [ASSUMED]
        "temp_sensor_lsb_C": 0.00565,           # [DS] TEMP_OUT 0.00565 degC/LSB (recalled)
        "gyro": {
            "noise_rms_dps": 0.26 / 60.0 * 10.0,  # [DS] ARW 0.26 deg/sqrt(h) = 0.00433 deg/sqrt(s) -> rms at 100 Hz
            "noise_ref_rate_hz": 100.0,         # [DS] the 100 Hz used above to express the ARW as an rms; rms/sqrt(rate) gives the ARW back
            "bias_instability_dps": 5.1 / 3600.0,  # [DS] 5.1 deg/h
            "bias_corr_time_s": 100.0,          # [ASSUMED]
            "rate_random_walk_dps_per_rts": 2.0e-5,  # [ASSUMED]
            "lsb_dps": 0.02,                    # [DS] 16-bit register (0.02 deg/s/LSB)
            "initial_bias_dps": 0.05,           # [ASSUMED]
            "initial_sf_ppm": 1000.0,           # [ASSUMED]
            "misalignment_deg": 0.05,           # [DS] axis-to-axis +-0.05 deg (recalled)
            "misalignment_tempco_deg_per_K": 2.0e-3,  # [ESTIMATE] thermal misalignment, see the note above GRADES
            "turn_on_bias_dps": 0.002,          # [ASSUMED] 1.3 % of the 0.15 deg/s curve
            "bias_temp_amplitude_dps": 0.15,    # [ASSUMED] ~0.0025 deg/s/degC x 60 degC
            "sf_temp_amplitude_ppm": 1500.0,    # [ASSUMED] ~25 ppm/degC x 60 degC
            "power_on_curve_fraction": 0.02,    # [ASSUMED] ordering per Liu et al. (gyros repeat better than accels)
            "temp_rate_coeff_dps_per_Cmin": 0.002,  # [ASSUMED]
            "g_sensitivity_dps_per_g": 0.009,   # [DS] linear-g 0.009 deg/s/g (recalled)
            "roll_coupling_dps": (0.02, 0.01),  # [ASSUMED] as adis16355, scaled like its other errors (1/5)
            "roll_coupling_ref_dps": 300.0,     # [ASSUMED] stated at 300 deg/s like adis16355
            "full_scale_dps": 450.0,            # [DS] measurement range +-450 deg/s (recalled)
        },
        "accel": {
            "noise_rms_mg": 0.029 / 60.0 / STANDARD_GRAVITY * 1000.0 * 10.0,  # [DS] VRW 0.029 m/s/sqrt(h) -> rms at 100 Hz
            "noise_ref_rate_hz": 100.0,         # [DS] the 100 Hz used above to express the VRW as an rms; rms/sqrt(rate) gives the VRW back
            "bias_instability_mg": 0.1,         # [DS] in-run bias 0.1 mg
            "bias_corr_time_s": 100.0,          # [ASSUMED]
            "rate_random_walk_mg_per_rts": 2.0e-4,  # [ASSUMED]
            "lsb_mg": 0.8,                      # [DS] 16-bit register (0.8 mg/LSB)
            "initial_bias_mg": 2.0,             # [ASSUMED]
            "initial_sf_ppm": 1000.0,           # [ASSUMED]
            "misalignment_deg": 0.035,          # [DS] axis-to-axis (recalled)
            "misalignment_tempco_deg_per_K": 2.0e-3,  # [ESTIMATE] thermal misalignment, see the note above GRADES
            "turn_on_bias_mg": 0.1,             # [ASSUMED] accels repeat worse than gyros (Liu et al.): 2 % of the 5 mg curve
            "bias_temp_amplitude_mg": 5.0,      # [ASSUMED] ~0.08 mg/degC x 60 degC
            "sf_temp_amplitude_ppm": 1000.0,    # [ASSUMED]
            "power_on_curve_fraction": 0.05,    # [ASSUMED] ordering per Liu et al. (accels repeat worse than gyros)
            "temp_rate_coeff_mg_per_Cmin": 0.05,  # [ASSUMED]
            "asymmetry_ppm": 100.0,             # [ASSUMED]
            "k2_mg_per_g2": 0.05,               # [ASSUMED]
        },
    },
    "ideal": {
        "description": "error-free sensor: every error, noise and lag is zero (for checks)",
        "sources": ["by definition"],
        "sample_rate_hz": 100.0,
        "temp_sensor_tau_s": 0.0,
        "temp_sensor_offset_std_C": 0.0,
        "temp_sensor_lsb_C": 0.0,
        "gyro": {
            "noise_rms_dps": 0.0, "noise_ref_rate_hz": 100.0, "bias_instability_dps": 0.0,
            "bias_corr_time_s": 100.0, "rate_random_walk_dps_per_rts": 0.0, "lsb_dps": 0.0,
            "initial_bias_dps": 0.0, "initial_sf_ppm": 0.0, "misalignment_deg": 0.0,
            "turn_on_bias_dps": 0.0, "bias_temp_amplitude_dps": 0.0, "sf_temp_amplitude_ppm": 0.0,
            "power_on_curve_fraction": 0.0, "temp_rate_coeff_dps_per_Cmin": 0.0,
            "g_sensitivity_dps_per_g": 0.0, "full_scale_dps": 0.0,  # 0: no range (never saturates)
        },
        "accel": {
            "noise_rms_mg": 0.0, "noise_ref_rate_hz": 100.0, "bias_instability_mg": 0.0,
            "bias_corr_time_s": 100.0, "rate_random_walk_mg_per_rts": 0.0, "lsb_mg": 0.0,
            "initial_bias_mg": 0.0, "initial_sf_ppm": 0.0, "misalignment_deg": 0.0,
            "turn_on_bias_mg": 0.0, "bias_temp_amplitude_mg": 0.0, "sf_temp_amplitude_ppm": 0.0,
            "power_on_curve_fraction": 0.0, "temp_rate_coeff_mg_per_Cmin": 0.0,
            "asymmetry_ppm": 0.0, "k2_mg_per_g2": 0.0,
        },
    },
}

# The sensor library (imu/sensor_library.toml): one grade per datasheet chip and the generic consumer grade,
# converted by the rule of imutherm.imu.sensor_library; the three grades above are unchanged.
from imutherm.imu.sensor_library import library_grades  # noqa: E402  (after GRADES: it scales from adis16355)

GRADES.update(library_grades(GRADES["adis16355"]))
