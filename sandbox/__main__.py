"""``python -m sandbox``: see :mod:`sandbox.cli`."""

import faulthandler
import sys

from sandbox.cli import main

# a crash inside Taichi's native code still prints where in Python it happened
faulthandler.enable()
sys.exit(main())
