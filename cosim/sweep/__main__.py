"""``python -m cosim.sweep SPEC ...`` is ``cosim sweep SPEC ...``."""
import sys

from .runner import _main

sys.exit(_main())
