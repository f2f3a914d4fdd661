"""Held-out splits by whole cells of the protocol, so that no test reading has a neighbouring
step or a repeat in training."""
from __future__ import annotations

import numpy as np

from .data import CalibrationData
from .errors import DatasetFormatError, TooFewRowsError
from .limits import MIN_ROWS


def _cells(values: np.ndarray, decimals: int = 1) -> np.ndarray:
    r = np.round(values, decimals)
    _, inv = np.unique(r, return_inverse=True)
    return inv.reshape(-1)


def split_groups(data: CalibrationData, mode: str = "auto", blocks: int = 20
                 ) -> tuple[np.ndarray, str]:
    """Group id per row (rows of a group always stay on one side) and the mode used.

    ``grid``: one group per (angle, height) cell, across sessions (needs both columns);
    ``trial``: one group per trial of each session (needs ``trial``); ``blocks``: ``blocks``
    contiguous runs of rows per session (readings in recording order). ``auto`` takes the
    first of these the data allows."""
    if mode == "auto":
        mode = "grid" if data.has_grid else "trial" if np.all(data.trial >= 0) else "blocks"
    if mode == "grid":
        if not data.has_grid:
            raise DatasetFormatError("the grid split needs angle_deg and height_mm columns")
        ia, ih = _cells(data.angle_deg), _cells(data.height_mm)
        return ia * 10_000 + ih, mode
    if mode == "trial":
        if not np.all(data.trial >= 0):
            raise DatasetFormatError("the trial split needs a trial column")
        return data.session * 10_000_000 + data.trial, mode
    if mode == "blocks":
        g = np.empty(len(data), np.int64)
        for s in np.unique(data.session):
            idx = np.flatnonzero(data.session == s)
            g[idx] = s * 10_000 + (np.arange(len(idx)) * blocks) // max(len(idx), 1)
        return g, mode
    raise ValueError(f"unknown split {mode!r} (auto, grid, trial, blocks)")


def split_holdout(data: CalibrationData, mode: str = "auto", folds: int = 4, fold: int = 0
                  ) -> tuple[np.ndarray, np.ndarray, str]:
    """Training and test row indices (about 1/``folds`` held out) and a description.

    In the grid mode, cell (i, j) (i-th angle, j-th height, sorted) is held out when
    ``(i + j) % folds == fold``: every angle and every height appears on both sides, and
    the held-out cells are new combinations. Other modes hold out every ``folds``-th group
    in a fixed shuffled order."""
    groups, used = split_groups(data, mode)
    if used == "grid":
        ia, ih = _cells(data.angle_deg), _cells(data.height_mm)
        test = (ia + ih) % folds == fold
        if not test.any() or test.all():
            test = ia % folds == fold
        how = (f"grid: whole (angle, height) cells held out, cell (i, j) when (i + j) % "
               f"{folds} == {fold}; all readings of a cell (every sweep, loading and "
               f"unloading) on one side")
    else:
        uniq = np.unique(groups)
        order = np.random.default_rng(12345).permutation(len(uniq))
        held = set(uniq[order[fold::folds]].tolist())
        test = np.isin(groups, list(held))
        how = (f"{used}: whole {'trials' if used == 'trial' else 'blocks of readings'} "
               f"held out (1 in {folds}), never split between the sides")
    tr, te = np.flatnonzero(~test), np.flatnonzero(test)
    if len(te) == 0 or len(tr) < max(MIN_ROWS // 2, 10) or len(np.unique(groups[test])) < 1:
        raise TooFewRowsError(f"too few trials ({len(np.unique(groups))} groups) to hold some "
                              f"out for testing; record more angles, heights or trials")
    return tr, te, how
