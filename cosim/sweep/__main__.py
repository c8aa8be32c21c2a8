"""``python -m cosim.sweep SPEC ...`` is ``cosim sweep SPEC ...``."""
import sys

from ..cli.main import main

sys.exit(main(["sweep", *sys.argv[1:]]))
