"""Every row of the bad-input table (issue 28): its exit status, one error line naming the
problem, no traceback, nothing damaged, no hang."""
from __future__ import annotations

import pytest

from .cases import CASES
from .harness import judge
from .workspace import build


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    w = build(tmp_path_factory.mktemp("robustness"))
    yield w
    w.close()


def test_the_table_is_large_enough():
    assert len(CASES) >= 150
    kinds = {"api" if c.api else "signal" if c.proc else "cli" for c in CASES}
    assert kinds == {"api", "signal", "cli"}


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_case(case, ws, tmp_path):
    out = judge(case, ws, tmp_path)
    assert out.handled, f"{case.id}: " + "; ".join(out.problems)
