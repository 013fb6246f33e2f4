"""Moved to :mod:`imutherm.unit.knobs` (the unit model is its own subpackage): this name stays importable.

``import imutherm.thermal.knobs`` gives the module :mod:`imutherm.unit.knobs` itself (the same object, so
users' scripts, monkeypatches and pickles that name the old path keep working). The FEM core does not
import it.
"""

import sys

from imutherm.unit import knobs as _moved

sys.modules[__name__] = _moved
