"""docs/recording.md lists exactly the event kinds the code writes."""
from __future__ import annotations

import re

from .conftest import ROOT

# Where the code names an event kind: Event(t, "kind", ...), write_event(name, "kind"...),
# the publisher's _event(feed, rec, name, "kind"...) and feed.event(name, "kind"...).
PATTERNS = [r'\bEvent\([^,\n]*(?:\([^)\n]*\))?[^,\n]*,\s*"(\w+)"',
            r'write_event\([^,()]+,\s*"(\w+)"', r'_event\(feed, rec, [^,()]+,\s*"(\w+)"',
            r'\.event\([^,()]+,\s*"(\w+)"']


def kinds_in_code() -> set[str]:
    found = set()
    for p in (ROOT / "host" / "fingertip").rglob("*.py"):
        text = p.read_text()
        for pat in PATTERNS:
            found.update(re.findall(pat, text))
    return found


def kinds_in_docs() -> set[str]:
    text = (ROOT / "docs" / "recording.md").read_text()
    block = text.split("<!-- event-kinds:start -->")[1].split("<!-- event-kinds:end -->")[0]
    return set(re.findall(r"^\| `(\w+)` \|", block, flags=re.M))


def test_docs_list_the_event_kinds_the_code_writes():
    code = kinds_in_code()
    assert {"contact_make", "contact_break", "vibration_onset", "tare", "start"} <= code
    assert kinds_in_docs() == code
