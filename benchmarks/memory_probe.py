"""The speed section's memory probe: the peak memory one tool needs for one image, in a fresh process.

    python -m benchmarks.memory_probe TOOL WARM_IMAGE IMAGE

TOOL is ``graphpose`` (the library as a user calls it: ``graphpose.read_image`` with its
default, then ``estimate_pose``), ``graphpose estimate`` (what the command line does: 8-bit
read, the size check, ``estimate_pose``) or ``opencv`` (the classic chain of
:func:`benchmarks.speed.opencv`). After a warm-up on WARM_IMAGE (imports and first-call costs,
on a small image) the peak resident set is reset to the present size through
``/proc/self/clear_refs`` (Linux 4.0 and later); the probe prints one JSON line:
``growth_mb`` (the peak while it handles IMAGE over the size before), ``found`` (a pose or
corners came out) and ``reset`` (without the reset the peak may be the warm-up's). Run from the
repository's root (:func:`benchmarks.speed.peak_memory` does, ``cwd`` the root).
"""

from __future__ import annotations

import json
import sys

from benchmarks._common import scaled_K, status_mb
from benchmarks.speed import BIG, ours, opencv

TOOLS = ("graphpose", "graphpose estimate", "opencv")


def _library(path, K):
    """``graphpose.read_image`` as a library user calls it (its default), then ``estimate_pose``."""
    import graphpose

    try:
        return graphpose.estimate_pose(graphpose.read_image(path), K, bounds=None)
    except graphpose.BoardNotFoundError:
        return None


def main(argv=None) -> int:
    tool, warm, path = sys.argv[1:] if argv is None else argv
    import cv2

    cv2.setNumThreads(1)
    run = {"graphpose": _library, "graphpose estimate": lambda p, k: ours(p, None, k),
           "opencv": lambda p, k: opencv(cv2, p, k)}[tool]
    run(warm, scaled_K((640, 480)))
    before = status_mb("VmRSS")
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        reset = True
    except OSError:
        reset = False
    out = run(path, scaled_K(BIG))
    peak = status_mb("VmHWM")
    print(json.dumps({"growth_mb": peak - before, "found": out is not None, "reset": reset}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
