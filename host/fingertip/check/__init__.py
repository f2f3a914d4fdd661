"""``fingertip check``: the bring-up check of a new fingertip (docs/bring-up.md).

- :mod:`.signals`, :mod:`.piezo`: the checks, pure functions of recorded arrays;
- :mod:`.limits`: the HX711 datasheet's figures and the limits applied;
- :mod:`.probe`: records segments from an open fingertip; :mod:`.guide`: who presses;
- :mod:`.run`: the sequence; :mod:`.results`: the table, the JSON and the exit code.
"""
from .results import FAIL, PASS, SKIP, WARN, Report, Result
from .run import run_check

__all__ = ["FAIL", "PASS", "SKIP", "WARN", "Report", "Result", "run_check"]
