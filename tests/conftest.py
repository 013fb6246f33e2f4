"""Shared fixtures: the reference layout as a dict, and a writer for mutated copies."""

import copy
import os

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the tomli backport (a dependency there)
    import tomli as tomllib

import pytest

# tests never draw to a screen
os.environ.setdefault("MPLBACKEND", "Agg")

# one BLAS thread per test worker when pytest-xdist runs one worker per core (the default `-n 2`): two
# workers of two OpenBLAS threads each on two cores spin against each other (measured: each worker at ~50 %
# of a core while four threads ran); the environment also reaches the commands the tests start as processes
if os.environ.get("PYTEST_XDIST_WORKER"):
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")
    from threadpoolctl import threadpool_limits

    _BLAS_LIMIT = threadpool_limits(limits=1)  # kept for the worker's life


@pytest.fixture(scope="session")
def reference_dict():
    from imutherm.geometry.layout import default_layout_path

    with open(default_layout_path(), "rb") as fh:
        return tomllib.load(fh)


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        if v != v:
            return "nan"
        if v in (float("inf"), float("-inf")):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def dump_toml(data: dict) -> str:
    """A minimal TOML writer for layout dicts (tables, arrays of tables, inline tables)."""
    lines = []
    for k, v in data.items():
        if not isinstance(v, (dict, list)) or (isinstance(v, list) and v and not isinstance(v[0], dict)):
            lines.append(f"{k} = {_toml_value(v)}")
    for k, v in data.items():
        if isinstance(v, dict):
            if k == "sites":  # a table of inline tables
                lines.append("[sites]")
                lines += [f"{a} = {_toml_value(b)}" for a, b in v.items()]
                continue
            simple = {a: b for a, b in v.items() if not isinstance(b, dict)}
            nested = {a: b for a, b in v.items() if isinstance(b, dict)}
            if simple or not nested:
                lines.append(f"[{k}]")
                lines += [f"{a} = {_toml_value(b)}" for a, b in simple.items()]
            for a, b in nested.items():
                lines.append(f"[{k}.{a}]")
                lines += [f"{c} = {_toml_value(d)}" for c, d in b.items()]
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                lines.append(f"[[{k}]]")
                lines += [f"{a} = {_toml_value(b)}" for a, b in item.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture
def write_layout(tmp_path, reference_dict):
    """write_layout(mutate) -> path of a copy of the reference layout changed by ``mutate(dict)``."""

    def make(mutate=None, name="layout.toml"):
        data = copy.deepcopy(reference_dict)
        if mutate:
            mutate(data)
        path = tmp_path / name
        path.write_text(dump_toml(data))
        return path

    return make


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Every test session keeps its reduced models in a cache folder of its own (never the user's)."""
    from imutherm.cache import CACHE_ENV

    old = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("imutherm_cache"))
    yield
    if old is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = old
