"""The command line (``fingertip ...``): one module per command group, each a thin layer that
parses arguments, calls the library and turns its errors into one line and an exit code (0
done; 1 the run found a problem; 2 a user error).

:mod:`.app` builds the parser from every group's ``add_parsers`` and holds :func:`main`, the
``fingertip`` entry point; ``python -m fingertip.cli`` runs the same.
"""
from .app import build_parser, main

__all__ = ["build_parser", "main"]
