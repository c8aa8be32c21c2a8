"""``python -m cosim.cli ...`` is the ``cosim`` command."""
import sys

from .main import main

sys.exit(main())
