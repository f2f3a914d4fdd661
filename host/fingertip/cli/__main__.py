"""``python -m fingertip.cli ...`` (the same as ``fingertip ...``)."""
import sys

from . import main

sys.exit(main())
