"""Every ``graphpose`` command of the documentation and of every ``--help`` example runs
(issue 26): the shell blocks of README.md and docs/*.md, and the example lines of each
subcommand's epilog, in a sandbox folder that holds the files they name (real sample images
from ../shared/data, rendered frames and views). A command shown with its exit code
(``(exit N)``) must end with that code; every other one must succeed (exit 0).

Three things are changed, and said here: ``graphpose batch`` estimates its images in the
test's process (:func:`_in_process`, the workers' own function; a local cluster's start would
cost some 10 s a command, and tests/batch runs the cluster); a rendering's frame count is cut to
:data:`FRAMES` (the command is the same, the sequence shorter), and paths into
``../shared/data`` and ``graphpose/data`` are made absolute. Commands that need what a test
cannot have (a Dask scheduler on another machine) are in :data:`NOT_RUN` with the reason, and
left out of the run (not skipped: a test checks that the list names only those); of a
pipeline (``graphpose ... | python ...``, ``... && evo_ape ...``) the graphpose part runs, and a
``$(...)`` substitution is run by bash in the sandbox.
"""

import contextlib
import glob
import io
import json
import os
import re
import shlex
import shutil

import numpy as np
import pytest

from tests.conftest import OPENCV_DIR, REAL_DIR, REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
#: Frames a rendered sequence is cut to.
FRAMES = 12
#: Commands not run, by a piece of their text, and why.
NOT_RUN = {
    "--scheduler tcp://HEAD:8786": "needs a Dask scheduler on another machine",
}
#: A shell block's line: a prompt is dropped; "# ..." comments are dropped.
_PROMPT = re.compile(r"^\$\s+")


def _doc_commands():
    """(where, command, expected exit code) of every graphpose command in the docs' blocks."""
    out = []
    for page in PAGES:
        for lang, block in re.findall(r"^```(sh|bash|text)\n(.*?)^```", page.read_text(), re.S | re.M):
            lines = block.replace("\\\n", " ").splitlines()
            for k, line in enumerate(lines):
                shown = line.strip()
                if lang == "text" and not _PROMPT.match(shown):
                    continue
                command = _PROMPT.sub("", shown)
                if not command.startswith("graphpose ") and command != "graphpose":
                    continue
                code = 0
                if lang == "text" and k + 1 < len(lines):
                    found = re.search(r"\(exit (\d+)\)\s*$", lines[k + 1])
                    code = int(found.group(1)) if found else 0
                out.append((page.name, command, code))
    return out


def _help_commands():
    from graphpose.cli import build_parser

    parser = build_parser()
    out = []
    for name, sub in next(a for a in parser._actions if a.dest == "command").choices.items():
        for line in (sub.epilog or "").replace("\\\n", " ").splitlines():
            if line.startswith("  graphpose "):
                out.append((f"{name} --help", line.strip(), 0))
    return out


def _unique(items):
    seen, out = set(), []
    for where, command, code in items:
        if command not in seen:
            seen.add(command)
            out.append((where, command, code))
    return out


ALL_COMMANDS = _unique(_doc_commands() + _help_commands())
COMMANDS = [c for c in ALL_COMMANDS if not any(piece in c[1] for piece in NOT_RUN)]


def test_the_commands_not_run_are_few_and_named():
    """Each entry of NOT_RUN leaves out a command the docs still hold, and nothing else is left out."""
    left_out = [c for c in ALL_COMMANDS if c not in COMMANDS]
    assert {piece for piece in NOT_RUN if any(piece in c for _, c, _ in left_out)} == set(NOT_RUN)
    assert len(left_out) <= 3


def test_there_are_commands_to_run():
    assert len(COMMANDS) >= 30
    assert any(where == "calibrate --help" for where, _, _ in COMMANDS)
    assert any(where == "cli.md" for where, _, _ in COMMANDS)


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory):
    """A folder holding every file the commands name."""
    if not (REAL_DIR.is_dir() and OPENCV_DIR.is_dir()):
        if os.environ.get("GRAPHPOSE_REQUIRE_REAL") == "1":
            pytest.fail("the real data folders are absent and GRAPHPOSE_REQUIRE_REAL=1")
        pytest.skip("the real data folders are absent")
    from graphpose.cli import main
    from graphpose.io.files import write_png
    from graphpose.synth.calibration import calibration_set, fisheye_camera

    s = tmp_path_factory.mktemp("sandbox")
    cases = json.loads((REAL_DIR / "cases.json").read_text())
    shutil.copy(REAL_DIR / "target_01.png", s / "board.png")
    (s / "pose.json").write_text(json.dumps({"T_WC": cases["cases"][0]["guess_T_WC"]}))
    bundled = json.loads((REPO / "graphpose" / "data" / "cases.json").read_text())
    for case in bundled["cases"]:
        case["image"] = str(REPO / "graphpose" / "data" / case["image"])
    (s / "cases.json").write_text(json.dumps(bundled))
    (s / "cut.png").write_bytes((REPO / "graphpose" / "data" / "synthetic_01.png").read_bytes()[:2000])
    lefts = sorted(OPENCV_DIR.glob("left*.jpg"))
    for name in ("left.opencv.yml", "camchain.kalibr.yaml", "right.opencv.xml"):
        shutil.copy(OPENCV_DIR / name, s / name)
    shutil.copy(OPENCV_DIR / "left.opencv.yml", s / "cam.yml")
    shutil.copy(OPENCV_DIR / "camchain.kalibr.yaml", s / "camchain.yaml")
    shutil.copy(lefts[0], s / "raw.jpg")
    for path in lefts:
        shutil.copy(path, s / path.name)
    for name in ("right01.jpg", "right02.jpg"):
        shutil.copy(OPENCV_DIR / name, s / name)
    for folder in ("left", "raw", "images", "cam1", "shots"):
        (s / folder).mkdir()
        for path in (lefts if folder == "shots" else lefts[:2]):
            shutil.copy(path, s / folder / path.name)
    (s / "campaign" / "a").mkdir(parents=True)
    for k in (1, 2):
        shutil.copy(REPO / "graphpose" / "data" / f"synthetic_0{k}.png", s / "campaign" / "a" / f"s{k}.png")
    third = str(REPO / "graphpose" / "data" / "synthetic_03.png")
    (s / "list.txt").write_text(third + "\n")
    (s / "todo.txt").write_text(third + "\nmissing.png\n")  # docs/batch.md's sample has an image missing
    (s / "more.txt").write_text(third + "\n")
    (s / "again.txt").write_text(third + "\n")
    named = [third, *map(str, (s / "cam1").glob("*.jpg")), *map(str, (s / "campaign" / "a").glob("*.png"))]
    (s / "bounds.json").write_text(json.dumps({path: None for path in named}))
    (s / "fisheye").mkdir()
    for k, image in enumerate(calibration_set(fisheye_camera(), 6, rng=2).images):
        write_png(s / "fisheye" / f"f{k}.png", image)
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["render-sequence", str(s / "seq"), "--frames", str(FRAMES), "-q"]) == 0
    (s / "frames").mkdir()  # named left_*.png, for docs/recordings.md's glob
    for k, path in enumerate(sorted((s / "seq").glob("frame_*.png"))):
        shutil.copy(path, s / "frames" / f"left_{k:03d}.png")
    (s / "times.txt").write_text("".join(f"{k / 30:.6f}\n" for k in range(FRAMES)))
    shutil.copy(s / "seq" / "truth.tum", s / "mocap.tum")
    _recordings(s)
    return s


def _recordings(s):
    """docs/recordings.md's inputs: a rendered calibration clip of OpenCV's left camera (cam.yml)
    waving the 9 x 6 board, as wave.mp4 and clip.mp4, its first frames as a ROS 1 bag, a ROS 2
    bag of PNG messages (both with the camera_info) and a list file."""
    from graphpose.board import Board
    from graphpose.io.cameras import read_camera
    from graphpose.io.files import write_png
    from graphpose.io.sources.bag_writer import write_bag
    from graphpose.io.sources.video_out import VideoWriter
    from graphpose.synth.clip import calibration_clip

    camera = read_camera(s / "cam.yml")
    with VideoWriter(s / "wave.mp4", 10) as w:
        for image in calibration_clip(camera, seconds=8.0, fps=10.0, rng=1, board=Board(9, 6, 0.025)).frames():
            w.add(image)
    # The tracking examples give no --board: the default board, its sharp whole views only (batch
    # wants a pose of every frame).
    clip = calibration_clip(camera, seconds=8.0, fps=10.0, rng=2, partial_share=0.0)
    rng = np.random.default_rng(3)
    images = [clip.frame(k, 10.0, rng=rng) for k in range(len(clip))
              if clip.subframes[k] == 1 and clip.visible[k] == 1.0][:FRAMES]
    with VideoWriter(s / "clip.mp4", 10) as w:
        for image in images:
            w.add(image)
    stamps = 100.0 + 0.1 * np.arange(FRAMES)
    write_bag(s / "run.bag", images[:FRAMES], stamps, fmt="ros1", topic="/cam0/image_raw", camera=camera)
    write_bag(s / "run_ros2", images[:FRAMES], stamps, fmt="ros2-sqlite3", topic="/camera/image_raw",
              compressed=True, camera=camera)
    (s / "clipframes").mkdir()
    for k, image in enumerate(images[:FRAMES]):
        write_png(s / "clipframes" / f"c{k:03d}.png", image)
    (s / "frames.txt").write_text("".join(f"clipframes/c{k:03d}.png\n" for k in range(FRAMES)))


def _in_process(paths, camera, board, *, bounds=None, robust=False, **cluster):
    """graphpose batch's images estimated in this process, as its workers would (a local Dask
    cluster's start costs some 10 s a command; the cluster itself is tests/batch's)."""
    from graphpose.batch.engine import _items
    from graphpose.batch.work import estimate_images

    yield from estimate_images(_items(paths, bounds), camera, board, robust)


def _shell_words(command: str, sandbox) -> list:
    """The words after 'graphpose' as bash makes them (a ``$(...)`` substitution run in the
    sandbox, with this Python as ``python``)."""
    import subprocess
    import sys

    rest = command.split("  #")[0].split(" # ")[0].split(None, 1)[1]
    env = dict(os.environ, PATH=f"{os.path.dirname(sys.executable)}{os.pathsep}{os.environ.get('PATH', '')}")
    done = subprocess.run(["bash", "-c", f"for a in {rest}; do printf '%s\\0' \"$a\"; done"], cwd=sandbox,
                          capture_output=True, text=True, env=env, check=True, timeout=60)
    return [w for w in done.stdout.split("\0") if w]


def _argv(command: str, sandbox) -> list:
    """The command's arguments after 'graphpose', paths made absolute, globs expanded, the
    frames cut to FRAMES."""
    command = command.split("  #")[0].split(" # ")[0]
    command = command.replace("../shared/data/", f"{REPO.parent}/shared/data/")
    command = re.sub(r"(?<![\w/.])graphpose/data/", f"{REPO}/graphpose/data/", command)
    command = re.sub(r"--frames \d+", f"--frames {FRAMES}", command)
    words = shlex.split(command)[1:]
    if words[:1] == ["render-sequence"] and "--frames" not in words:
        words += ["--frames", str(FRAMES)]
    out = []
    for word in words:
        matches = sorted(glob.glob(str(sandbox / word))) if any(c in word for c in "*?") else []
        out += matches or [word]
    return out


@pytest.mark.slow  # every documented shell command in a subprocess, on a rendered sandbox
@pytest.mark.parametrize("where, command, code", COMMANDS, ids=[f"{w}: {c[:60]}" for w, c, _ in COMMANDS])
def test_the_documented_command_runs(where, command, code, sandbox, monkeypatch):
    from graphpose.cli import main

    monkeypatch.chdir(sandbox)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setattr("graphpose.batch.engine.estimate_many", _in_process)
    command = re.split(r"\s(?:\||&&)\s", command)[0]  # a pipeline's graphpose part
    argv = _shell_words(command, sandbox) if "$(" in command else _argv(command, sandbox)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        got = main(argv)
    assert got == code, f"{where}: {command}\nexit {got}, expected {code}\n{err.getvalue()[-2000:]}"
