"""``python -m fingerfriction.cli``: the ``fingerfriction`` console script."""

import sys

from . import main

sys.exit(main())
