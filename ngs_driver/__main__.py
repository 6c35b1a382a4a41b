"""``python -m ngs_driver ...`` = the ``dam-seismic`` console script (ngs_driver.cli)."""
import sys

from .cli import main

sys.exit(main())
