"""Typed values and options shared by the subcommands: bounds, K, camera, board, progress.

Each parser turns one argument string into a checked value or raises
``argparse.ArgumentTypeError`` with what was expected and what came; :func:`add_target_options`
declares ``--K`` and ``--board`` once, with the project's defaults named in ``--help``, and
:func:`add_camera_option` ``--camera FILE`` (a calibration file with the lens model) and
``--camera-name NAME`` (which camera of a Kalibr camchain) for the subcommands that work on raw
images. A user's image has no default camera: :func:`camera_from_args` refuses to go on
without ``--camera`` or ``--K`` (or a case file's camera) in the one line :data:`NO_CAMERA`.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import numpy as np

from .._checks import check_count, check_number, check_range
from ..board import Board
from ..geometry import K_from_params
from ..camera_models import PinholeCamera
from ..errors import InputError
from ..io.files import dumps_json, write_json

#: The project's camera (the ROB501 sample set's): fx, fy, cx, cy in pixels. Only what the
#: project renders itself (``graphpose render-sequence``) and the tests use it: a user's image
#: never falls back to it (:data:`NO_CAMERA`).
DEFAULT_K = (564.9, 564.3, 337.3, 226.5)

#: The one line (exit 2) of ``estimate``, ``track`` and ``batch`` given an image and no camera.
NO_CAMERA = ("no camera: give --camera FILE (a calibration with the lens model: OpenCV YAML/XML, ROS, "
             "Kalibr or graphpose JSON) or --K FX,FY,CX,CY (a pinhole camera, images undistorted); "
             "no calibration yet? make one with 'graphpose calibrate' (see 'graphpose calibrate --help')")


#: How ``--board``'s square side is written, for every command's help.
BOARD_UNITS = "square side in metres, or in mm or cm written after it (9x6x0.025 = 9x6x25mm)"


def add_target_options(parser: argparse.ArgumentParser, file_note: str = "") -> None:
    """Add ``--K FX,FY,CX,CY`` and ``--board COLSxROWSxSQUARE_M`` to ``parser``.

    ``file_note`` names where else a value may come from (e.g. "with --cases, the file's"),
    for the help text; :func:`target_from_args` applies the project's defaults.
    """
    board = Board()
    note = f"; {file_note}" if file_note else ""
    parser.add_argument("--K", dest="K", type=parse_K, metavar="FX,FY,CX,CY",
                        help="camera intrinsics in pixels (a fifth number is the skew), images "
                        f"undistorted; an image needs this or --camera (no default){note}")
    parser.add_argument("--board", type=parse_board, metavar="COLSxROWSxSQUARE_M",
                        help=f"inner junctions per row and per column, {BOARD_UNITS} (default: "
                        f"the project's target, {board.cols}x{board.rows}x{board.square_m}{note})")


def target_from_args(args, K=None, board=None):
    """``(K (3, 3), Board)`` from ``--K``/``--board``, else ``K``/``board``, else the project's
    (for what the project renders itself; a user's image takes :func:`camera_from_args`)."""
    K = args.K if args.K is not None else (K if K is not None else K_from_params(*DEFAULT_K))
    board = args.board if args.board is not None else (board if board is not None else Board())
    return K, board


def add_camera_option(parser: argparse.ArgumentParser, file_note: str = "") -> None:
    """Add ``--camera FILE`` and ``--camera-name NAME`` to ``parser`` (which has
    :func:`add_target_options`' ``--K``): the camera with its lens model, from a calibration file,
    and which camera of a Kalibr camchain it is; :func:`camera_from_args` reads them."""
    note = f"; {file_note}" if file_note else ""
    parser.add_argument("--camera", type=Path, metavar="FILE",
                        help="the camera with its lens distortion, from a calibration file (OpenCV YAML/XML, "
                        "ROS camera_info, Kalibr camchain (cam0 unless --camera-name), graphpose JSON): images "
                        f"are raw; not with --K{note}")
    parser.add_argument("--camera-name", metavar="NAME",
                        help="with --camera: the camera of a Kalibr camchain that holds several (cam0, cam1, ...; "
                        "default cam0); for a ROS camera_info file, checked against its camera_name")


def check_camera_options(args) -> None:
    """UsageError when ``--camera`` and ``--K`` are both given, or ``--camera-name`` without
    ``--camera`` (before any file is read)."""
    from . import UsageError

    if args.camera is not None and args.K is not None:
        raise UsageError("give either --camera FILE (a calibration with the lens model) or --K FX,FY,CX,CY "
                         "(a pinhole camera, images undistorted), not both")
    name = getattr(args, "camera_name", None)
    if name is not None and args.camera is None:
        raise UsageError(f"--camera-name {name} chooses a camera of the --camera FILE, and no --camera was given")


def camera_from_args(args, camera=None, board=None, source: str = ""):
    """``(Camera, Board)`` from ``--camera`` or ``--K`` and ``--board``, else ``camera``/``board``
    (a case file's; the board is the project's when neither gives one).

    There is no default camera: without ``--camera``, ``--K`` and ``camera`` this is the
    usage error :data:`NO_CAMERA` (preceded by ``source``, e.g. the case file, when given).

    Raises
    ------
    UsageError
        If both ``--camera`` and ``--K`` are given, ``--camera-name`` without ``--camera``,
        or no camera at all.
    InputError
        If the ``--camera`` file cannot be read (:func:`graphpose.io.cameras.read_camera`),
        or holds no camera of the ``--camera-name`` (the message names those it holds).
    """
    from . import UsageError

    check_camera_options(args)
    if args.camera is not None:
        from ..io.cameras import read_camera  # the camera files' readers: not for --K

        try:
            camera = read_camera(args.camera, name=getattr(args, "camera_name", None))
        except InputError as exc:
            raise InputError(f"--camera: {exc}") from None
        if not hasattr(camera, "K"):  # a rig file (graphpose.rig.Rig): one camera is wanted here
            raise UsageError(f"--camera {args.camera} holds a rig of {len(camera)} cameras ({', '.join(camera.names)}): "
                             "pick one with --camera-name, or give the rig's images with --rig")
    elif args.K is not None:
        camera = PinholeCamera(args.K)
    elif camera is None:
        raise UsageError(f"{source}: {NO_CAMERA}" if source else NO_CAMERA)
    board = args.board if args.board is not None else (board if board is not None else Board())
    return camera, board


def camera_file(args, source=None):
    """``(file, name)`` the camera came from, for records: ``--camera FILE`` as typed and
    ``--camera-name``; ``(None, None)`` for ``--K``; else ``(source, None)`` (a case file's)."""
    if args.camera is not None:
        return str(args.camera), getattr(args, "camera_name", None)
    if args.K is not None:
        return None, None
    return (None if source is None else str(source)), None


def write_json_option(path, value) -> None:
    """Write ``value`` where a ``--json`` option says: ``"-"`` standard output, a path a file
    (whole or not at all, :func:`graphpose.io.files.write_json`), None nowhere."""
    if path == "-":
        sys.stdout.write(dumps_json(value))
    elif path is not None:
        write_json(path, value)


def check_output_folder(path, option: str) -> None:
    """The folder an output goes to exists, before the work starts; ``path`` None or ``"-"``
    (stdout) writes no file. The message names the folder as the user typed it."""
    if path is None or str(path) == "-":
        return
    folder = Path(path).parent if str(Path(path).parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"{option}: folder {folder} does not exist")


def parse_bounds(text: str) -> np.ndarray:
    """``"u1,v1,...,u4,v4"`` -> (2, 4) polygon in pixels (row 0 = u); ArgumentTypeError if malformed."""
    values = _numbers(text, (8,), "bounds", "U1,V1,U2,V2,U3,V3,U4,V4")
    return values.reshape(4, 2).T.copy()


def parse_K(text: str) -> np.ndarray:
    """``"fx,fy,cx,cy"`` (or with a fifth value, the skew) -> (3, 3) K; ArgumentTypeError if malformed."""
    values = _numbers(text, (4, 5), "K", "FX,FY,CX,CY")
    try:
        return K_from_params(*values)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_board(text: str) -> Board:
    """``"COLSxROWSxSQUARE_M"`` (or ``...mm``, ``...cm``) -> :class:`Board`; ArgumentTypeError if
    malformed or over 1 m a square (:meth:`graphpose.board.Board.parse`: "did you mean 25 mm (0.025)?")."""
    try:
        return Board.parse(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_positive(text: str) -> float:
    """A positive finite number; ArgumentTypeError otherwise."""
    return _checked(text, lambda: check_number("", float(text), 0.0, strict=True), "a positive number")


def parse_non_negative(text: str) -> float:
    """A finite number >= 0; ArgumentTypeError otherwise."""
    return _checked(text, lambda: check_number("", float(text), 0.0), "a number >= 0")


def parse_count(minimum: int):
    """Parser of an integer >= ``minimum``; ArgumentTypeError otherwise."""
    return lambda text: _checked(text, lambda: check_count("", int(text), minimum), f"an integer >= {minimum}")


def parse_distance(text: str) -> tuple:
    """``"NEAR,FAR"`` metres, ``0 < NEAR <= FAR``; ArgumentTypeError otherwise."""
    try:
        near, far = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NEAR,FAR in metres, got {text!r}") from None
    return _checked(text, lambda: check_range("", (near, far), "", 0.0, strict=True), "0 < NEAR <= FAR")


def _checked(text: str, check, expected: str):
    """``check()``, with its ValueError (InputError included) as argparse's 'expected ..., got TEXT'."""
    try:
        return check()
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None


def _numbers(text, counts, name, form) -> np.ndarray:
    parts = [p for p in re.split(r"[,;\s]+", text.strip()) if p]
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} must be comma-separated numbers {form}, got {text!r}") from None
    if values.size not in counts:
        raise argparse.ArgumentTypeError(f"{name} needs {' or '.join(map(str, counts))} numbers ({form}), "
                                         f"got {values.size} in {text!r}")
    if not np.all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"{name} must be finite numbers, got {text!r}")
    return values


class Progress:
    """A one-line progress bar on a terminal ``stream``; silent for one image or a non-terminal."""

    def __init__(self, total: int, stream, width: int = 24):
        self.total, self.stream, self.width = total, stream, width
        self.enabled = total > 1 and hasattr(stream, "isatty") and stream.isatty()
        self._shown = 0

    def show(self, done: int, name: str) -> None:
        """Draw the bar with ``done`` of ``total`` finished, now working on ``name``."""
        if not self.enabled:
            return
        filled = self.width * done // self.total
        line = f"[{'#' * filled}{'.' * (self.width - filled)}] {done}/{self.total} {name}"[:78]
        self.stream.write("\r" + line.ljust(self._shown))
        self.stream.flush()
        self._shown = len(line)

    def clear(self) -> None:
        """Erase the bar (before other output, and at the end)."""
        if self.enabled and self._shown:
            self.stream.write("\r" + " " * self._shown + "\r")
            self.stream.flush()
            self._shown = 0


def board_hint(message: str, given: bool = False) -> str:
    """``message`` with how to give the board when it says the board found is not the spec's
    (the detector's ``found a 9 x 6 board ...; the board spec says 8 x 6``): the default board
    when no ``--board`` was ``given``, else how ``--board`` is read; for ``graphpose estimate``
    and ``graphpose batch``, whose messages it completes."""
    if "board spec" not in message:
        return message
    how = ("COLSxROWSxSQUARE_M: inner junctions along a row and down a column, and the square's side in "
           "metres")
    if given:
        return f"{message} (check --board {how})"
    d = Board()
    return f"{message} (the default board is {d.cols}x{d.rows}x{d.square_m}; give yours with --board {how})"
