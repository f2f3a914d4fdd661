"""The record package's names resolve to the same objects whatever order they are asked in."""
from __future__ import annotations

import subprocess
import sys


def test_export_is_the_function_after_its_module_loaded_first():
    # A fresh interpreter: the order of first use is what broke (``ExportError`` first made
    # ``export`` the submodule).
    code = ("from fingertip.record import ExportError\n"
            "from fingertip.record import export\n"
            "import inspect\n"
            "assert inspect.isfunction(export), type(export)\n")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_unknown_name_is_an_attribute_error():
    import fingertip.record as record

    try:
        record.no_such_name  # noqa: B018
    except AttributeError as e:
        assert "no_such_name" in str(e)
    else:
        raise AssertionError("expected AttributeError")
