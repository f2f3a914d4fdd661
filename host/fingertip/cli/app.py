"""The ``fingertip`` command line: one parser over the command groups (one module each,
thin: parse arguments, call the library)."""
from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from .. import __version__
from ..protocol import PROTOCOL_MAJOR, PROTOCOL_MINOR
from . import calibrate as calibration_cli
from . import check as check_cli
from . import classify as classifier_cli
from . import demo as demo_cli
from . import device as device_cli
from . import experiment as tasks_cli
from . import network as network_cli
from . import record as record_cli
from . import sim as sim_cli
from .argtypes import dispatch

log = logging.getLogger("fingertip")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="fingertip",
        description="Host bridge of the open-source multi-modal tactile fingertip.")
    p.add_argument("--version", action="version",
                   version=f"fingertip {__version__} (wire protocol v{PROTOCOL_MAJOR}."
                           f"{PROTOCOL_MINOR})")
    p.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    device_cli.add_parsers(sub)
    demo_cli.add_parsers(sub)
    sim_cli.add_group(sub)
    record_cli.add_parsers(sub)
    calibration_cli.add_parsers(sub)
    check_cli.add_parsers(sub)
    classifier_cli.add_parsers(sub)
    tasks_cli.add_parsers(sub)
    network_cli.add_parsers(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    return dispatch(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
