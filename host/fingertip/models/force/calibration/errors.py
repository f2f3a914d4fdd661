"""Why a calibration dataset is refused: one exception type per cause, each with a ``code``."""
from __future__ import annotations

from ....errors import Error


class CalibrationError(Error, ValueError):
    """The data cannot determine the force model. ``code`` names the reason (stable, for
    scripts); the command line exits with status 2 for every one of them (a
    :class:`~fingertip.errors.Error` and a ValueError)."""

    exit_code = 2

    code = "calibration_error"


class DatasetFormatError(CalibrationError):
    """The file or folder is not a calibration dataset (missing columns, unreadable)."""

    code = "format"


class MixedUnitsError(CalibrationError):
    """Rows of several fingertips: each unit needs its own calibration."""

    code = "mixed_units"


class TooFewRowsError(CalibrationError):
    code = "too_few_rows"


class NonFiniteError(CalibrationError):
    code = "non_finite"


class SaturationError(CalibrationError):
    code = "saturated"


class DeadChannelError(CalibrationError):
    code = "dead_channel"


class SingleDirectionError(CalibrationError):
    """All forces along one direction: one angle only, the map to (Fx, Fy) is rank deficient."""

    code = "single_angle"


class IllConditionedError(CalibrationError):
    code = "ill_conditioned"
