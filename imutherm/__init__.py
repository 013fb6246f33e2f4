"""imutherm: thermal FEM design studies of small MEMS IMUs, end to end to attitude error.

Subpackages follow the flow of the design notes:
``geometry`` (layouts -> parts -> conforming mesh), ``thermal`` (FEM),
``imu`` (sensor error model, calibration, attitude filters),
``studies`` (the chains), ``reports`` (the only place that draws), ``cli``.
Each lives in the repository's top-level folder of its name (``thermal/`` is ``imutherm.thermal``; the
mapping is ``package-dir`` in pyproject.toml); this folder holds the small modules shared by them.
"""

__version__ = "0.1.0"


class InputError(ValueError):
    """Bad user input: the message names the file, the part and the field.

    The CLI turns it into a one-line message and a non-zero exit status.
    """


class ConvergenceError(RuntimeError):
    """A solve did not converge or diverged (Newton, the linear solver, or a transient's iterates); no result
    is returned. Not bad input: the CLI exits with status 3 (bad input: 2); the message names the likely cause.
    """
