"""The ``stiffkit`` command line: one program, one module per subcommand.

Each module parses its arguments (``register``) and calls its stage
(``run``); the numbers, tables, plots and files come from the stage."""

from .app import build_parser, main

__all__ = ["main", "build_parser"]
