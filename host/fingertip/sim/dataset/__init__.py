"""Datasets from the virtual fingertip: calibration sweeps and labelled vibration recordings.

``fingertip sim dataset calibration OUT`` and ``fingertip sim dataset vibration OUT`` (see
:mod:`fingertip.cli.sim`) call :func:`write_calibration` and :func:`write_vibration`.

- Calibration: the paper's sweep
  (:func:`~fingertip.sim.device.calibration_rig.calibration_sweep`) on one or more virtual
  units, one CSV per unit, in the layout of ``fingertip export``'s ``<name>.csv``
  (``device_time_us``, ``ch0..ch3``, masks, ``fx fy fz``) plus the sweep's ground truth
  (angle, contact height, displacement, loading/unloading, trial, step, unit).
- Vibration: one sub-folder per class of WAV (or FLAC) files, the layout that
  ``fingertip train material|shake FOLDER`` reads, a ``manifest.csv`` (file, class, seed,
  the scene's parameters) and, for cup slides, sidecar CSVs of rim times and robot Z.

Every folder gets a ``dataset.json`` (what was written, with which parameters and the
SHA-256 of the parameter file). It is written first with ``"complete": false`` and
rewritten at the end, so an interrupted run is recognisable. Files hold no wall-clock time:
the same arguments and seed give byte-identical files. See docs/simulation.md.

The parts: :mod:`.output` (the folder, ``dataset.json``, progress), :mod:`.sweep_csv`
(calibration sweeps as CSV) and :mod:`.recordings` (vibration recordings).
"""
from .output import (
    GENERATOR,
    META_FILE,
    DatasetError,
    DatasetResult,
    Progress,
    params_sha256,
    prepare_output,
)
from .recordings import (
    DEFAULT_RECORDINGS,
    FORMATS,
    KINDS,
    MANIFEST_COLUMNS,
    MANIFEST_FILE,
    MAX_RATE_HZ,
    MIN_RATE_HZ,
    TASK_AMPLITUDE_GAIN,
    TASK_BOX_ITEMS,
    TASK_MAINS_HZ,
    TASK_PREAMP_GAIN,
    plan_vibration,
    resample,
    write_vibration,
)
from .sweep_csv import CALIBRATION_COLUMNS, read_calibration_csv, write_calibration

__all__ = [
    "CALIBRATION_COLUMNS", "DEFAULT_RECORDINGS", "FORMATS", "GENERATOR", "KINDS",
    "MANIFEST_COLUMNS", "MANIFEST_FILE", "MAX_RATE_HZ", "META_FILE", "MIN_RATE_HZ",
    "TASK_AMPLITUDE_GAIN", "TASK_BOX_ITEMS", "TASK_MAINS_HZ", "TASK_PREAMP_GAIN",
    "DatasetError", "DatasetResult", "Progress", "params_sha256", "plan_vibration",
    "prepare_output", "read_calibration_csv", "resample", "write_calibration",
    "write_vibration",
]
