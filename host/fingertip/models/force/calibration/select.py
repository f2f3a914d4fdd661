"""Model selection: the fastest model whose held-out error is within a bound of the best."""
from __future__ import annotations

from collections.abc import Sequence

from .report import ModelResult


def choose(results: Sequence[ModelResult], bound_pct: float) -> tuple[str, float, str]:
    """The fastest (single-frame p50) model whose held-out RMSE is within ``bound_pct``
    percent of the best; latencies within 5 % of each other count as a tie (the timing
    noise of a shared machine), which the lower RMSE wins."""
    best = min(r.rmse_n for r in results)
    limit = best * (1 + bound_pct / 100)
    ok = [r for r in results if r.rmse_n <= limit + 1e-12]
    fastest = min(r.latency_us_single for r in ok)
    tied = [r for r in ok if r.latency_us_single <= fastest * 1.05]
    pick = min(tied, key=lambda r: (r.rmse_n, r.latency_us_single))
    rule = (f"Rule: the fastest model (one frame, p50) whose held-out RMSE is within "
            f"{bound_pct:g} % of the best ({best:.3f} N, so <= {limit:.3f} N); latencies "
            f"within 5 % count as equal and the lower RMSE wins.")
    return pick.name, best, rule
