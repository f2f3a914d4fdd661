"""The three rooms of `models` (docs/design.md): `nets` imports neither `force` nor
`vibration`, and `force` never imports `vibration`, so a force pipeline loads no spectrogram
code and the networks stay shared. Imports inside functions count too."""
from __future__ import annotations

import pytest

from tests.test_import_layers import PACKAGE, imports_of

MODELS = PACKAGE / "models"
FORBIDDEN = {"nets": {"force", "vibration"}, "force": {"vibration"}}


@pytest.mark.parametrize("room", sorted(FORBIDDEN))
def test_a_room_imports_only_what_it_may(room):
    hits = [f"{p.relative_to(PACKAGE.parent)}:{imp.line} imports {'.'.join(imp.target)}"
            for p in sorted((MODELS / room).rglob("*.py"))
            for imp in imports_of(p, PACKAGE)
            if imp.target[1:2] == ["models"] and imp.target[2:3]
            and imp.target[2] in FORBIDDEN[room]]
    assert not hits, "\n".join(hits)


def test_every_module_of_models_sits_in_a_room():
    loose = sorted(p.name for p in MODELS.glob("*.py") if p.name != "__init__.py")
    assert not loose
