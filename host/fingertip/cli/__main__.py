"""``python -m fingertip.cli ...`` (the same as ``fingertip ...``)."""
import sys

from .app import main

sys.exit(main())
