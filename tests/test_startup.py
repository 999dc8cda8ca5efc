"""Starting ``graphpose estimate``: the command imports only what one image needs.

The start-up's time is the benchmark's (``python -m benchmarks speed``); here, what it must
not import, in a fresh process: SciPy, scikit-image, PyYAML, Pillow (for a grey PNG),
matplotlib, Dask, importlib.metadata, numpy.ma (which any ``np.median`` imports) and shutil.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import PROJECT_K_OPTION

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "skimage", "yaml", "PIL", "matplotlib", "dask", "imageio", "importlib.metadata", "numpy.ma",
         "graphpose.track.tracker", "graphpose.batch", "graphpose.calibrate",
         "shutil")  # argparse's width lookup imports it, with lzma and bz2 (graphpose.cli.HelpFormatter does not)

_PROBE = """\
import io, json, sys, contextlib
from graphpose.cli import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main(sys.argv[1:])
print(json.dumps({"code": code, "lines": out.getvalue().count("\\n"),
                  "heavy": sorted(m for m in %r if m in sys.modules)}))
""" % (HEAVY,)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_estimate_on_a_grey_png_imports_nothing_heavy():
    image = REPO / "graphpose" / "data" / "synthetic_01.png"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-c", _PROBE, "estimate", str(image), "--K", PROJECT_K_OPTION],
                         cwd=REPO, env=env, capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["code"] == 0 and result["lines"] > 5
    assert result["heavy"] == []


@pytest.mark.slow  # the command in a fresh process
def test_the_program_ends_with_its_code_and_its_output_whole(tmp_path):
    """``python -m graphpose estimate`` ends without Python's teardown (graphpose.cli.entry):
    its report and its JSON file are whole, and a failure keeps its exit code."""
    image = REPO / "graphpose" / "data" / "synthetic_01.png"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    run = [sys.executable, "-m", "graphpose", "estimate", str(image), "--K", PROJECT_K_OPTION]
    done = subprocess.run(run + ["--json", str(tmp_path / "out.json")], cwd=REPO, env=env, capture_output=True,
                          text=True)
    assert done.returncode == 0 and "T_WC" in done.stdout and done.stdout.endswith("\n")
    assert len(json.loads((tmp_path / "out.json").read_text())) == 1
    done = subprocess.run(run[:4] + [str(tmp_path / "missing.png")] + run[5:], cwd=REPO, env=env,
                          capture_output=True, text=True)
    assert done.returncode == 2 and done.stderr.startswith("graphpose estimate: error: image file not found")
