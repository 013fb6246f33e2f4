"""Attitude filters (roll / pitch): Liu et al. 2012 gated strapdown, the horizontal-attitude KF paper's KF, ungated baseline, peer, Wang et al.'s AEKF.

``FILTERS`` lists the names used in result files: ``gated``, ``kf``,
``ungated``, ``fusion``, ``aekf``, ``aekf_gnss`` (the last needs GNSS fixes). Each filter has a procedural step function, a thin
class over it, and a batch runner returning an :class:`AttitudeEstimate`:

=========  ==============================  ====================  ===============
name       step                            class                 batch
=========  ==============================  ====================  ===============
gated      :func:`gated_step`              GatedStrapdown        run_gated
kf         :func:`kf_step`                 GravityKF             run_kf
ungated    gated_step (thresholds=None)    ComplementaryFilter   run_ungated
fusion     :func:`fusion_step`             FusionPeer            run_fusion
aekf       (numba loop)                    --                    run_aekf
aekf_gnss  (numba loop, GNSS velocity)     --                    run_aekf
=========  ==============================  ====================  ===============

``PEERS`` (``vqf``, ``madgwick``, ``mahony``, ``ekf``): batch runners only
(:mod:`imutherm.imu.filters.peers`); ``ALL_FILTERS`` = FILTERS + PEERS, the built-in set. The registry
(:mod:`imutherm.imu.filters.registry`) declares each of them once (runner, parameters, source, plot colour,
needs-GNSS); the study, the command and the plots read it.
"""

from imutherm.imu.filters.aekf import AEKFParams, AEKFTrace, run_aekf
from imutherm.imu.filters.common import AttitudeEstimate, initial_quat
from imutherm.imu.filters.fusion_peer import FusionParams, FusionPeer, fusion_step, run_fusion
from imutherm.imu.filters.gate import GateThresholds, gate_noise_std, gate_signals, gate_thresholds
from imutherm.imu.filters.gated import (ComplementaryFilter, GatedParams, GatedState, GatedStrapdown,
                                        default_thresholds, gated_step, run_gated, run_ungated)
from imutherm.imu.filters.gravity_kf import GravityKF, KFParams, KFState, kf_step, run_kf

from imutherm.imu.filters.peers import (EKFParams, MadgwickParams, MahonyParams, VQFParams, run_ekf, run_ekf_many,
                                        run_madgwick, run_mahony, run_vqf)

#: Wang et al.'s adaptive EKF without and with simulated GNSS velocity aiding (:mod:`imutherm.imu.filters.aekf`)
ADAPTIVE = ("aekf", "aekf_gnss")
FILTERS = ("gated", "kf", "ungated", "fusion") + ADAPTIVE
#: further 6D peers (VQF, ahrs Madgwick / Mahony / EKF), see :mod:`imutherm.imu.filters.peers`
PEERS = ("vqf", "madgwick", "mahony", "ekf")
ALL_FILTERS = FILTERS + PEERS

__all__ = [
    "FILTERS", "AttitudeEstimate", "initial_quat", "GateThresholds", "gate_thresholds", "gate_signals",
    "gate_noise_std", "GatedParams", "GatedState", "GatedStrapdown", "ComplementaryFilter", "gated_step",
    "run_gated", "run_ungated", "default_thresholds", "KFParams", "KFState", "GravityKF", "kf_step", "run_kf",
    "FusionParams", "FusionPeer", "fusion_step", "run_fusion", "PEERS", "ALL_FILTERS", "EKFParams", "MadgwickParams",
    "MahonyParams", "VQFParams", "run_ekf", "run_ekf_many", "run_madgwick", "run_mahony", "run_vqf",
    "ADAPTIVE", "AEKFParams", "AEKFTrace", "run_aekf",
]
