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


_RACE = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, sys.argv[1])
    import kernel_mod
    open(os.path.join(sys.argv[1], f"ready-{os.getpid()}"), "w").close()
    while len([f for f in os.listdir(sys.argv[1]) if f.startswith("ready-")]) < 2:   # both start together
        time.sleep(0.01)
    assert kernel_mod.poly(2.0) == 11.0
    st = kernel_mod.poly.dispatcher.stats
    print(sum(st.cache_misses.values()), sum(st.cache_hits.values()))
""")


def test_two_processes_on_a_cold_cache_compile_a_kernel_once(tmp_path):
    """The first calls hold a lock of the machine: of two processes started together on an empty numba cache,
    one compiles (a cache miss) and the other loads what it wrote (a hit), instead of both compiling."""
    (tmp_path / "kernel_mod.py").write_text(textwrap.dedent("""
        from imutherm.lazy_jit import njit

        @njit(cache=True)
        def poly(x):
            return 1.0 + x + 2.0 * x * x
    """))
    env = dict(__import__("os").environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               IMUTHERM_JIT_LOCK=str(tmp_path / "jit.lock"))
    procs = [subprocess.Popen([sys.executable, "-c", _RACE, str(tmp_path)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1] for o in outs]
    counts = sorted(tuple(map(int, o[0].split())) for o in outs)
    assert counts == [(0, 1), (1, 0)], counts   # (misses, hits): one compiled, the other loaded


import numba  # noqa: E402  (the kernel below leaves nopython mode through numba.objmode)

_LOCK_DEPTHS = []


def _record_lock_depth():
    from imutherm import lazy_jit

    _LOCK_DEPTHS.append(getattr(lazy_jit._LOCAL, "depth", 0))


@njit(cache=False)
def _reports_the_lock(x):
    with numba.objmode():   # back in Python during the kernel's run: is this thread inside the lock?
        _record_lock_depth()
    return x + 1.0


def test_a_first_call_runs_outside_the_lock():
    """The lock covers the compile (or the cache load) for the arguments' types, not the first run: two workers'
    first runs of a long kernel are not serialised."""
    _LOCK_DEPTHS.clear()
    assert not _reports_the_lock.dispatcher.signatures   # this is the first call
    assert _reports_the_lock(1.0) == 2.0 and _reports_the_lock(2.0) == 3.0
    assert _LOCK_DEPTHS == [0, 0], _LOCK_DEPTHS
    assert len(_reports_the_lock.dispatcher.signatures) == 1   # compiled once, for float64
