"""The ``graphpose`` command line: argument parsing and error handling in one place.

Each subcommand is a module ``graphpose/cli/<name>.py`` with ``add_parser(subparsers)``,
which adds a parser called ``<name>`` (``subparsers.add_parser("<name>", ...)``), and
``run(args) -> int``, which turns the typed arguments into library calls and returns the
exit code. :data:`SUBCOMMANDS` lists them; :func:`main` calls the chosen module's ``run``.
``graphpose`` with no argument at all runs ``graphpose estimate`` on the bundled example.

Exit codes: 0 success; 1 an estimate failed (no board found, no convergence); 2 bad usage or
input (malformed option, missing or unreadable file); 130 interrupted (every ``--help``
says so: :func:`exit_codes_help`). Errors that graphpose raises on purpose
(:class:`graphpose.errors.GraphposeError`) and argument errors become one line on stderr,
prefixed ``graphpose COMMAND:`` (:func:`prefix`; ``graphpose:`` before a command is known);
anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys

from ..errors import GraphposeError, InputError

#: Subcommand modules under graphpose/cli/, in the order ``--help`` lists them.
SUBCOMMANDS = ("estimate", "track", "render", "batch", "calibrate")

#: Exit codes.
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130

PROG = "graphpose"


def prefix(command: str | None = None) -> str:
    """``graphpose COMMAND``, the start of every line a command writes on stderr (``graphpose``
    before a command is known)."""
    return f"{PROG} {command}" if command else PROG


def exit_codes_help(failed: str | None, usage: str = "bad usage or input") -> str:
    """The exit codes' paragraph of a command's ``--help``: 0, 1 ``failed`` (none when None:
    a command that cannot fail), 2 ``usage``, 130."""
    import textwrap

    one = "" if failed is None else f" 1 {failed},"
    return textwrap.fill(f"exit codes: 0 success,{one} 2 {usage}, 130 interrupted (Ctrl-C).", 88)


class UsageError(InputError):
    """A command-line argument is missing or malformed (exit code 2)."""


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser that raises :class:`UsageError` instead of printing usage and exiting.

    ``commands`` holds the subcommands' parser names (``render-sequence`` for the module
    ``render``), filled in by :func:`build_parser`.
    """

    commands: tuple = ()

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """argparse's formatter (descriptions kept as written) sized to the terminal without
    :mod:`shutil`: argparse's own looks the width up through :func:`shutil.get_terminal_size`,
    whose import (lzma, bz2 behind it) falls on every command's start, help or not. The same
    rule: ``$COLUMNS`` when set, else the terminal's width, else 80; less 2, as argparse's."""

    def __init__(self, prog, indent_increment=2, max_help_position=24, width=None):
        if width is None:
            width = _terminal_columns() - 2
        super().__init__(prog, indent_increment=indent_increment, max_help_position=max_help_position, width=width)


def _terminal_columns() -> int:
    """The terminal's width in columns: ``$COLUMNS``, else the width of the terminal on
    standard output, else 80."""
    try:
        columns = int(os.environ.get("COLUMNS", "0"))
    except ValueError:
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns if columns > 0 else 80


class _VersionAction(argparse.Action):
    """``--version``: the installed version, looked up only when asked (``importlib.metadata``
    takes 50 ms to import, a twentieth of a one-image ``graphpose estimate``)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show program's version number and exit"):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{parser.prog} {_version()}")
        parser.exit()


def build_parser(commands=SUBCOMMANDS) -> argparse.ArgumentParser:
    """The top-level parser with the subcommands ``commands`` (modules of :data:`SUBCOMMANDS`,
    all by default) added."""
    from .. import __doc__ as package_doc

    parser = ArgumentParser(
        prog=PROG,
        description=package_doc.splitlines()[0]
        + " With no argument, runs 'graphpose estimate' on the bundled example.",
        epilog=exit_codes_help("an estimate failed") + "\nRun 'graphpose COMMAND --help' for a command's options.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action=_VersionAction)
    subparsers = parser.add_subparsers(title="commands", dest="command", metavar="COMMAND", required=True)
    for name in commands:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    parser.commands = tuple(subparsers.choices)
    return parser


def main(argv=None) -> int:
    """Run the command line; returns the exit code (see the module docstring).

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.
    """
    argv = _attach_negative_lists(list(sys.argv[1:] if argv is None else argv))
    if not argv:
        argv = ["estimate"]
    parser = None
    try:
        parser = _parser_for(argv[0])
        _check_command(argv[0], parser.commands)
        try:
            args, extra = parser.parse_known_args(argv)
        except SystemExit as done:  # --help and --version print and exit 0
            return int(done.code or 0)
        if extra:
            raise UsageError(f"unrecognized arguments: {' '.join(extra)} (see '{PROG} {args.command} --help')")
        return int(importlib.import_module(f"{__name__}.{args.command}").run(args))
    except GraphposeError as exc:
        print_error(exc, prog=_prog(exc, argv, parser))
        return exit_code(exc)
    except KeyboardInterrupt:
        print(f"{_prog(None, argv, parser)}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader went away (graphpose ... | head): stop quietly, and keep Python's own
        # flush at exit from failing on the closed pipe as well.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_FAILED


def _parser_for(first: str) -> argparse.ArgumentParser:
    """The parser for a command line starting with ``first``: where it names a subcommand,
    with that one alone (so ``graphpose estimate`` imports no other command's modules: the
    tracker's, Dask's set-up), else with all of them (for ``--help`` and the messages that
    list them)."""
    if first in SUBCOMMANDS:
        parser = build_parser((first,))
        if first in parser.commands:
            return parser
    return build_parser()


#: Commands after which the process ends without Python's teardown (:func:`entry`).
QUICK_EXIT = ("estimate",)


def entry() -> None:
    """The ``graphpose`` program (the console script and ``python -m graphpose``): :func:`main`,
    then the process's exit with its code.

    After ``graphpose estimate`` (:data:`QUICK_EXIT`; also ``graphpose`` alone, which runs it),
    the standard streams are flushed and the process ends at once (``os._exit``), without
    Python's teardown of the modules it imported: GTSAM's takes 30-40 ms, a tenth of the
    command on one image. Everything the command writes is closed by then (its files are
    written whole and renamed into place, :func:`graphpose.io.files.atomic_write`), and it
    starts no threads or workers. The other commands end as usual.
    """
    code = main()
    argv = sys.argv[1:]
    if not argv or argv[0] in QUICK_EXIT:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except BrokenPipeError:  # the reader went away after the last line
            code = code or EXIT_FAILED
        os._exit(code)
    sys.exit(code)


#: A comma-separated list of numbers that starts with a minus sign, e.g. "-3.5,10,...".
_NEGATIVE_LIST = re.compile(r"^-\.?\d[\d.eE+-]*(,[-+]?\.?\d[\d.eE+-]*)+$")


def _attach_negative_lists(argv: list) -> list:
    """Write ``--opt -1,2,...`` as ``--opt=-1,2,...``.

    argparse takes a value starting with '-' for an option unless it is a single number, so
    ``--bounds -3,10,...`` would fail; a comma-separated list of numbers is never an option.
    """
    out = []
    for arg in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NEGATIVE_LIST.match(arg):
            out[-1] = f"{out[-1]}={arg}"
        else:
            out.append(arg)
    return out


def _check_command(first: str, commands) -> None:
    """UsageError pointing to ``graphpose estimate PATH`` when the first argument is a path
    (an existing file or folder, or a name with an ending) rather than a command."""
    if first in commands or first.startswith("-") or not (os.path.exists(first) or os.path.splitext(first)[1]):
        return
    raise UsageError(f"'{first}' is not a command; for the camera pose in an image or a folder of images, "
                     f"run: {PROG} estimate {first} --camera FILE (or --K FX,FY,CX,CY)")


def exit_code(exc: GraphposeError) -> int:
    """2 for bad usage or input (:class:`InputError`), 1 for an estimate that failed."""
    return EXIT_USAGE if isinstance(exc, InputError) else EXIT_FAILED


def error_line(exc: BaseException, context: str = "") -> str:
    """The one-line message for ``exc``, prefixed by ``context`` (an image name) when given."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return f"{context}: {text}" if context else text


def print_error(exc: BaseException, context: str = "", prog: str = PROG) -> None:
    """Write ``prog: error: [context: ]message`` as one line on stderr."""
    print(f"{prog}: error: {error_line(exc, context)}", file=sys.stderr, flush=True)


def _prog(exc, argv, parser) -> str:
    """``graphpose COMMAND`` once the command is known (every error of a command's run, its
    arguments' included), else ``graphpose``."""
    commands = parser.commands if parser is not None else ()
    return prefix(argv[0] if argv and argv[0] in commands else None)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("graphpose")
    except PackageNotFoundError:
        return "unknown"
