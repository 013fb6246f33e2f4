"""imutherm.lazy_jit: numba's njit deferred to a kernel's first call (the study's processes do not carry numba
through the thermal solves)."""

import pickle
import subprocess
import sys
import textwrap

import numpy as np

from imutherm.lazy_jit import LazyKernel, njit


@njit(cache=False)
def _scale(a, b):
    return 2.0 * a + b


@njit
def _sum_scaled(x):
    s = 0.0
    for i in range(x.size):
        s += _scale(x[i], 1.0)   # a lazy kernel called from a kernel: numba compiles it as its callee
    return s


def test_a_kernel_calling_a_lazy_kernel_compiles_and_runs():
    x = np.arange(5.0)
    assert isinstance(_sum_scaled, LazyKernel) and isinstance(_scale, LazyKernel)
    assert _sum_scaled(x) == float(np.sum(2.0 * x + 1.0))
    assert _scale(3.0, 1.0) == 7.0
    assert _sum_scaled.__name__ == "_sum_scaled" and _sum_scaled.dispatcher.signatures   # compiled by numba


def test_numba_s_other_forms_keep_their_options_and_signatures():
    def add(a, b):
        return a + b
    direct = njit(add, cache=False)          # njit(f, **options): a kernel, not a decorator
    typed = njit("float64(float64, float64)")(add)
    assert isinstance(direct, LazyKernel) and direct.options == {"cache": False} and direct(1.0, 2.0) == 3.0
    assert typed(1.0, 2.0) == 3.0 and len(typed.dispatcher.signatures) == 1   # compiled for the given signature


def test_a_lazy_kernel_pickles_by_name():
    assert pickle.loads(pickle.dumps(_scale)) is _scale


def test_importing_the_study_and_the_filters_does_not_import_numba():
    """The command imports every filter before it forks its workers; numba comes only with the first kernel."""
    code = textwrap.dedent("""
        import sys
        import imutherm.cli.compare, imutherm.studies.end_to_end, imutherm.imu.filters
        from imutherm.studies.end_to_end import StudyConfig
        StudyConfig()
        assert "numba" not in sys.modules, "numba imported"
        import numpy as np
        from imutherm.imu.filters import run_ekf
        gyro = np.zeros((2000, 3)); accel = np.tile([0.0, 0.0, -9.81], (2000, 1))
        run_ekf(gyro, accel, 0.01)
        assert "numba" in sys.modules, "the kernel ran without numba"
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
