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
    """Bad user input: the message names the file, the part and the field, and what would be valid.

    Raised by every reader (layouts, board files, measured files, IMU logs) and every public function on a bad
    argument, before anything is written. The CLI turns it into a one-line message and exit status 2.

    Examples
    --------
    >>> from imutherm import InputError
    >>> from imutherm.geometry.layout import load_layout
    >>> try:
    ...     load_layout("my_unit.toml")
    ... except InputError as err:
    ...     print(err)
    my_unit.toml: layout file not found; built-in layouts: imu_cardguide, imu_reference
    """


class ConvergenceError(RuntimeError):
    """A solve did not converge or diverged (Newton, the linear solver, or a transient's iterates); no result
    is returned. Not bad input: the CLI exits with status 3 (bad input: 2); the message names the likely cause.

    Examples
    --------
    A 10 mm block cooled by radiation alone (a nonlinear law) with 1 W inside needs more than two Newton steps:

    >>> import numpy as np
    >>> from imutherm import ConvergenceError
    >>> from imutherm.geometry.grid import TensorGrid
    >>> from imutherm.thermal import Radiation, ThermalProblem, solve_steady
    >>> lines = np.linspace(0.0, 0.01, 3)
    >>> block = TensorGrid(lines, lines, lines, np.zeros((2, 2, 2), np.int32), ("block",), {})
    >>> faces = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
    >>> problem = ThermalProblem(block, k=200.0, rho_c=2.4e6, q=1.0 / 0.01**3, ambient_C=20.0,
    ...                          boundary={face: (Radiation(0.9),) for face in faces})
    >>> try:
    ...     solve_steady(problem, max_iter=2)
    ... except ConvergenceError as err:
    ...     print(err)
    solve_steady: Newton did not converge in 2 iterations (...); raise max_iter or check the boundary laws
    """
