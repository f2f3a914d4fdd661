"""The command line (``fingertip ...``): one module per command group, each a thin layer that
parses arguments and calls the library; errors become one line and an exit status in one
place (:mod:`.stopping`: 0 done; 1 a failure at run time; 2 the user's input; 130
interrupted).

:mod:`.app` builds the parser from every group's ``add_parsers`` and holds the parser's
``main``; :func:`main` here (the ``fingertip`` entry point; ``python -m fingertip.cli`` runs
the same) handles the stop signals *before* it imports the command modules (this module
imports nothing at all, and ``import fingertip`` loads its layers only on first use), so a
Ctrl-C in the first fraction of a second is one line too.
"""
from __future__ import annotations

__all__ = ["build_parser", "main"]


def main(argv: list[str] | tuple[str, ...] | None = None) -> int:
    """Run ``fingertip`` with ``argv`` (default: the process's arguments); the exit status."""
    from .stopping import configure_logging, failed, interrupted, stop_signals

    try:
        with stop_signals():
            configure_logging()
            try:
                from .app import main as run

                return run(argv)
            except KeyboardInterrupt as e:  # while importing or building the parser
                return interrupted(e)
            except Exception as e:  # noqa: BLE001 - e.g. an import the interrupt broke
                return failed(e)
    except KeyboardInterrupt as e:
        # A signal that came as the handlers were put in or back: Python runs a handler
        # between bytecodes, so one caught in the last install raises just after it.
        configure_logging()
        return interrupted(e)


def __getattr__(name: str) -> object:
    if name == "build_parser":
        from .app import build_parser

        return build_parser
    raise AttributeError(name)
