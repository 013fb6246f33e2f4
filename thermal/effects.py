"""Moved to :mod:`imutherm.unit.effects` (the unit model is its own subpackage): this name stays importable.

``import imutherm.thermal.effects`` gives the module :mod:`imutherm.unit.effects` itself (the same object, so
users' scripts, monkeypatches and pickles that name the old path keep working). The FEM core does not
import it.
"""

import sys

from imutherm.unit import effects as _moved

sys.modules[__name__] = _moved
