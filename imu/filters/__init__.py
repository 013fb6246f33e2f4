"""Attitude filters (roll / pitch): Liu et al. 2012 gated strapdown, the horizontal-attitude KF paper's KF, ungated baseline, peer, Wang et al.'s AEKF.

The registry (:mod:`imutherm.imu.filters.registry`) is the one list of filters: each is declared there once
(name as used in result files, runner, parameter class, source, plot colour, needs-GNSS, tuning axes, whether
the study's answer shows it); the study, the command, the benchmarks and the plots read it
(:func:`~imutherm.imu.filters.registry.filter_names`, ``study_filters``, ``tuned_filters``). The built-in ones:
each of ours has a procedural step function, a thin class over it, and a batch runner returning an
:class:`AttitudeEstimate`:

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

and the peers ``vqf``, ``madgwick``, ``mahony``, ``ekf``: batch runners only
(:mod:`imutherm.imu.filters.peers`). :func:`imutherm.imu.filters.run.run_filters` runs any of them on one record
(:class:`~imutherm.imu.filters.registry.FilterInputs`, from which each filter reads what it needs).
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

__all__ = [
    "AttitudeEstimate", "initial_quat", "GateThresholds", "gate_thresholds", "gate_signals",
    "gate_noise_std", "GatedParams", "GatedState", "GatedStrapdown", "ComplementaryFilter", "gated_step",
    "run_gated", "run_ungated", "default_thresholds", "KFParams", "KFState", "GravityKF", "kf_step", "run_kf",
    "FusionParams", "FusionPeer", "fusion_step", "run_fusion", "EKFParams", "MadgwickParams",
    "MahonyParams", "VQFParams", "run_ekf", "run_ekf_many", "run_madgwick", "run_mahony", "run_vqf",
    "AEKFParams", "AEKFTrace", "run_aekf",
]
