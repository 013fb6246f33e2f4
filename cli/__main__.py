"""``python -m imutherm.cli COMMAND ...``: the same as the ``imutherm`` console script."""

import sys

from imutherm.cli import main

sys.exit(main())
