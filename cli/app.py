"""The ``stiffkit`` command line: one program, one subcommand per job.

Each subcommand lives in its own module that provides ``register(sub)``
(adds its parser and sets ``func``); modules are imported lazily so that
``stiffkit --help`` is fast and a broken optional dependency only affects
its own command.

Every failure is one line on stderr, ``stiffkit COMMAND: error: ...``:

====  =====================================================================
exit  meaning
====  =====================================================================
0     success (also when stdout is a pipe closed early, e.g. ``| head``)
2     bad input: a file, row, key, option or value (StiffkitError, argparse,
      a file that cannot be read or written, out of memory)
3     internal error: a bug in stiffkit (``STIFFKIT_TRACEBACK=1`` shows it)
130   interrupted (Ctrl-C); 143 terminated (SIGTERM). Outputs are written
      atomically, so an interrupted run leaves the old file or none.
====  =====================================================================

Warnings (values implausible for their unit, a symmetrised matrix, an
ignored cache entry) are one line each, ``stiffkit COMMAND: warning: ...``.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import re
import signal
import sys
import threading
import traceback
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any, NoReturn, TextIO

from ..errors import StiffkitError, StiffkitWarning
from ..version import __version__

# (module, one-line summary); the module's register() builds the parser
COMMANDS = [
    ("stiffkit.cli.field", "field: fit (t, phi) of node displacement fields; compliance from six load cases"),
    ("stiffkit.cli.robot", "robot: manipulator stiffness from generalised springs (Orthoglide, SMG, your tree)"),
    ("stiffkit.cli.stiffness", "stiffness: tool compliance/stiffness of a robot model with values"),
    ("stiffkit.cli.fit", "fit: identify elastostatic parameters from measured deflections"),
    ("stiffkit.cli.diagnose", "diagnose: is the residual noise? rank the missing effects"),
    ("stiffkit.cli.evaluate", "evaluate: the errors of a model with values on (fresh) measurements, nothing fitted"),
    ("stiffkit.cli.compensate", "compensate: joint commands that make the identified robot reach the nominal targets"),
    ("stiffkit.cli.plan", "plan: which postures to measure (optimal calibration experiment)"),
    ("stiffkit.cli.compare", "compare: two fit results side by side"),
    ("stiffkit.cli.synth", "synth: calibration data with a known truth and hidden effects"),
    ("stiffkit.cli.link", "link: a link's compliance matrix from its CAD (Gmsh + CalculiX + field fit)"),
    ("stiffkit.cli.convergence", "convergence: mesh-convergence study of a link (Table 5)"),
    ("stiffkit.cli.sweep", "sweep: design sweep of a link on Dask (any LINK.toml keys)"),
    ("stiffkit.cli.demo", "demo: the main job on a built-in example"),
]

EPILOG = """\
examples:
  stiffkit demo                       run the built-in example
  stiffkit link examples/beam.toml --json beam.json
  stiffkit convergence examples/beam.toml --orders 1,2 --sizes 5,3,2 -j 2
  stiffkit field nodes.csv disp1.csv ... disp6.csv --reference 1,0,0 --loads 1000,1,1,1,1,1
  stiffkit synth kr270 --out kr270    calibration data of a KR-270-like robot
  stiffkit fit kr270/model.toml kr270/measurements.csv
  stiffkit diagnose kr270/model.toml kr270/measurements.csv
  stiffkit evaluate fitted.toml fresh.csv    a fitted model's errors on new postures
  stiffkit compensate identified.toml targets.csv --out commands.csv
  stiffkit plan kr270/model.toml --select 12 --task task.csv --out postures.csv   what to measure
  stiffkit COMMAND --help             what a command does, its inputs and outputs

All files are SI (m, N, N m, rad). Bad input gives one line naming the file,
row or key and the value, and exit status 2; a value implausible for its
unit (a length in mm, an angle in degrees) gives a warning with the fix.
A negative value may follow its option directly: --posture -0.5,0.2,...
"""

#: a token that starts with "-" and a digit (or ".digit") is a value, not an option
_NEGATIVE = re.compile(r"^-\.?\d")


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit status 2) and values that start
    with "-" accepted after their option (``--point -50,0,0``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE

    def error(self, message: str) -> NoReturn:
        m = re.match(r"argument ([^:]+): (.*)$", message, re.S)
        if m and m.group(2).startswith(m.group(1).split("/")[-1]):
            message = m.group(2)  # the value check already names the option
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="stiffkit",
        description="How stiff a robot is, and why it bends the way it does.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"stiffkit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for modname, _summary in COMMANDS:
        importlib.import_module(modname).register(sub)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that every cleanup runs."""


class _PipeSafe:
    """stdout that stops writing, silently, once its reader has gone
    (``stiffkit ... | head``): the command still finishes its files."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self.closed_pipe = False

    def _gone(self) -> None:
        self.closed_pipe = True
        try:  # later flushes (at exit too) go nowhere instead of failing
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):
            pass

    def write(self, text: str) -> int:
        if self.closed_pipe:
            return len(text)
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._gone()
            return len(text)

    def flush(self) -> None:
        if self.closed_pipe:
            return
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._gone()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


@contextmanager
def _session(command: list) -> Iterator[None]:
    """Warnings as one line each, stdout safe against a closed pipe, SIGTERM
    raised as an interrupt; everything restored afterwards (main() may be
    called in-process, e.g. by tests)."""
    old_show = warnings.showwarning
    old_stdout = sys.stdout

    seen = set()

    def show(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        # the same finding reached twice (an option, then the API; a file read twice)
        keys = {("text", str(message))}
        if getattr(message, "key", None) is not None:
            keys.add(message.key)
        if keys & seen:
            return
        seen.update(keys)
        kind = "" if issubclass(category, StiffkitWarning) else f"({category.__name__}) "
        print(f"stiffkit {command[0] or ''}".rstrip() + f": warning: {kind}{message}", file=sys.stderr)

    warnings.showwarning = show
    sys.stdout = _PipeSafe(old_stdout)
    main_thread = threading.current_thread() is threading.main_thread()
    old_term = None
    if main_thread:

        def on_term(signum: int, frame: FrameType | None) -> NoReturn:
            raise Terminated()

        old_term = signal.signal(signal.SIGTERM, on_term)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.filterwarnings("ignore", category=DeprecationWarning)
            warnings.filterwarnings("ignore", category=PendingDeprecationWarning)
            warnings.showwarning = show
            yield
    finally:
        try:
            sys.stdout.flush()
        except Exception:  # noqa: BLE001 - nothing left to report it to
            pass
        sys.stdout = old_stdout
        warnings.showwarning = old_show
        if main_thread and old_term is not None:
            signal.signal(signal.SIGTERM, old_term)


def _oserror(exc: OSError) -> str:
    """One line for a file error, naming the user's path (never a temporary)."""
    name = exc.filename if exc.filename is not None else ""
    if isinstance(exc, FileNotFoundError):
        return f"file not found: {name}" if name else f"file not found ({exc.strerror or exc})"
    if exc.errno == errno.ENOSPC:
        return f"{name}: no space left on the device"
    text = exc.strerror or str(exc)
    return f"{name}: {text}" if name else text


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    names = {m.rpartition(".")[2] for m, _ in COMMANDS}
    # the command's name for warnings given while the arguments are parsed
    command = [next((a for a in argv if a in names), None)]
    with _session(command):
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help, --version, or a usage error (one line, status 2)
            return int(exc.code or 0) if not isinstance(exc.code, str) else 2
        command[0] = getattr(args, "command", None)
        if not getattr(args, "func", None):
            parser.print_help()
            return 2
        name = f"stiffkit {args.command}"
        try:
            return int(args.func(args) or 0)
        except StiffkitError as exc:
            print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
            return 2
        except OSError as exc:
            print(f"{name}: error: {_oserror(exc)}", file=sys.stderr)
            return 2
        except MemoryError:
            print(f"{name}: error: out of memory (the problem is too large for this machine)", file=sys.stderr)
            return 2
        except Terminated:
            print(f"{name}: terminated", file=sys.stderr)
            return 143
        except KeyboardInterrupt:
            print(f"{name}: interrupted", file=sys.stderr)
            return 130
        except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback on request
            if os.environ.get("STIFFKIT_TRACEBACK"):
                traceback.print_exc()
            print(
                f"{name}: internal error: {type(exc).__name__}: {_one_line(exc)} "
                "(a bug in stiffkit; STIFFKIT_TRACEBACK=1 shows where)",
                file=sys.stderr,
            )
            return 3


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__
