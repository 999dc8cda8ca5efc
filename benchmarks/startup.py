"""Starting the command: ``graphpose estimate IMAGE --K ...`` in a fresh process, beside a
six-line OpenCV script doing the same (imread, findChessboardCorners, cornerSubPix,
solvePnP) in a fresh process; part of the ``speed`` section (:mod:`benchmarks.speed`).

Both run as a user runs them: a new Python each time, single-threaded, the wall time from
the start of the process to its exit, the two timed in turn. The Python files of both are
compiled to bytecode once before the timing, as ``pip install`` leaves an installed package
(numpy's and OpenCV's are; a checkout run with ``PYTHONDONTWRITEBYTECODE`` would compile
graphpose's 40-odd modules again in every process, about 0.1 s): the bytecode goes to a
temporary folder (``PYTHONPYCACHEPREFIX``), not into the tree. Beside the wall times, the
import times measured inside a fresh process: ``graphpose.cli``, then the estimate path
(``graphpose.cli.estimate``, everything the command imports before it reads the image), of
which numpy and GTSAM; and the OpenCV script's imports (numpy, then cv2).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks._common import REPO, median, single_thread_environment

#: The OpenCV script, as a user would write it for one image of the default board.
OPENCV_SCRIPT = """\
import sys, cv2, numpy as np
image = cv2.imread(sys.argv[1], cv2.IMREAD_GRAYSCALE)
found, corners = cv2.findChessboardCorners(image, (8, 6))
corners = cv2.cornerSubPix(image, corners, (11, 11), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01))
W = np.array([[0.0635 * x, 0.0635 * y, 0.0] for y in range(6) for x in range(8)])
print(cv2.solvePnP(W, corners, np.array([[float(v) for v in r.split(",")] for r in sys.argv[2].split(";")]), None))
"""

#: Import times inside a fresh process (ms), printed as JSON: graphpose's side.
_GRAPHPOSE_IMPORTS = """\
import json, time
t0 = time.perf_counter()
import graphpose.cli
t1 = time.perf_counter()
import numpy
t2 = time.perf_counter()
import gtsam
t3 = time.perf_counter()
import graphpose.cli.estimate
t4 = time.perf_counter()
print(json.dumps({"graphpose.cli": t1 - t0, "estimate path": t4 - t1, "of which numpy": t2 - t1,
                  "of which gtsam": t3 - t2}))
"""

#: The same for the OpenCV script's imports.
_OPENCV_IMPORTS = """\
import json, time
t0 = time.perf_counter()
import numpy
t1 = time.perf_counter()
import cv2
t2 = time.perf_counter()
print(json.dumps({"numpy": t1 - t0, "cv2": t2 - t1}))
"""


def _environment(pycache: str) -> dict:
    """Single-threaded, this tree's graphpose first on the path, bytecode kept in ``pycache``."""
    env = single_thread_environment()
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPYCACHEPREFIX"] = pycache
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [env.get("PYTHONPATH")])])
    return env


def _wall(command, env) -> float:
    """Seconds from starting ``command`` to its exit; it must succeed."""
    t = time.perf_counter()
    subprocess.run(command, cwd=REPO, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return time.perf_counter() - t


def _imports(code, env) -> dict:
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(image, K, repeats: int) -> tuple:
    """The command and the script on ``image`` (a 640 x 480 file of the default board) with the
    camera matrix ``K`` (3, 3), each run ``repeats`` times in turn in fresh processes: (figure,
    block) for the speed section."""
    fx, fy, cx, cy = (float(K[i, j]) for i, j in ((0, 0), (1, 1), (0, 2), (1, 2)))
    with tempfile.TemporaryDirectory() as folder:
        script = Path(folder) / "opencv_pose.py"
        script.write_text(OPENCV_SCRIPT)
        env = _environment(str(Path(folder) / "pycache"))
        ours = [sys.executable, "-m", "graphpose", "estimate", str(image), "--K", f"{fx!r},{fy!r},{cx!r},{cy!r}"]
        peer = [sys.executable, str(script), str(image), ";".join(",".join(repr(float(v)) for v in row) for row in K)]
        _wall(ours, env), _wall(peer, env)  # bytecode compiled, files in the page cache
        t_ours, t_peer, imp_ours, imp_peer = [], [], [], []
        for _ in range(repeats):
            t_ours.append(_wall(ours, env))
            t_peer.append(_wall(peer, env))
            imp_ours.append(_imports(_GRAPHPOSE_IMPORTS, env))
            imp_peer.append(_imports(_OPENCV_IMPORTS, env))
    a, b = median(t_ours), median(t_peer)
    figure = {"figure": f"graphpose estimate on one image in a fresh process ({Path(image).name}, 640 x 480), wall "
                        f"time, median of {repeats}",
              "unit": "ms", "fmt": ".0f", "graphpose": 1e3 * a, "peer_name": "OpenCV script (fresh process)",
              "peer": 1e3 * b, "ratio": a / b, "goal": "<= 1.6x the OpenCV script", "met": bool(a / b <= 1.6)}
    names_ours, names_peer = list(imp_ours[0]), list(imp_peer[0])
    row = ([1e3 * a, 1e3 * b, a / b] + [1e3 * median([d[n] for d in imp_ours]) for n in names_ours]
           + [1e3 * median([d[n] for d in imp_peer]) for n in names_peer])
    block = {"title": "Starting the command: one image in a fresh process (median ms)",
             "text": "`graphpose estimate IMAGE --K ...` and a six-line OpenCV script (imread, findChessboardCorners, "
                     "cornerSubPix, solvePnP) on the same file, each a new Python process, timed in turn, "
                     "single-threaded, with their bytecode compiled beforehand as an installed package has it. Beside "
                     "them, the import times inside a fresh process: `graphpose.cli`, then the estimate path "
                     "(`graphpose.cli.estimate`: all the command imports before it reads the image) and within it "
                     "numpy and GTSAM; and the script's numpy and cv2. Each process also pays the interpreter's own "
                     "start (its site packages included).",
             "values": {}, "columns": ["graphpose estimate", "OpenCV script", "ratio"]
             + [f"import {n}" for n in names_ours] + [f"OpenCV script: import {n}" for n in names_peer],
             "formats": [".0f", ".0f", ".2f"] + [".0f"] * (len(names_ours) + len(names_peer)),
             "rows": [row]}
    return figure, block


if __name__ == "__main__":
    from benchmarks._common import K_REAL

    figure, block = measure(REPO / "graphpose" / "data" / "synthetic_01.png", np.asarray(K_REAL), 5)
    print(json.dumps(figure, indent=1))
    print(dict(zip(block["columns"], np.round(block["rows"][0], 2))))
