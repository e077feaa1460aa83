"""``python -m occlux_lab.cycles``: see :mod:`occlux_lab.cycles.cli`."""

import sys

from occlux_lab.cycles.cli import main

sys.exit(main())
