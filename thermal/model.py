"""Moved to :mod:`imutherm.unit.model` (the unit model is its own subpackage): this name stays importable.

``import imutherm.thermal.model`` gives the module :mod:`imutherm.unit.model` itself (the same object, so
users' scripts, monkeypatches and pickles that name the old path keep working). The FEM core does not
import it.
"""

import sys

from imutherm.unit import model as _moved

sys.modules[__name__] = _moved
