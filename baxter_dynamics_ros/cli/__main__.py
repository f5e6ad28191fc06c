"""``python -m baxter_dynamics_ros.cli ARGS...``: the ``baxter-dynamics`` command."""

import sys

from .main import main

sys.exit(main())
