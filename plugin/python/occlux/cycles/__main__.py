"""``python -m occlux.cycles``: see :mod:`occlux.cycles.cli`."""

import sys

from occlux.cycles.cli import main

sys.exit(main())
