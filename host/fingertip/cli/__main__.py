"""``python -m fingertip.record record|replay|export ...`` (the same as ``fingertip ...``)."""
import sys

from .cli import main

sys.exit(main())
