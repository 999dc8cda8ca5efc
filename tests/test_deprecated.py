"""The old names kept for one release: each still answers, with a DeprecationWarning."""

import numpy as np
import pytest

from graphpose import estimate_pose_from_points
from graphpose.calibrate.result import SolverCrossCheck
from graphpose.geometry import T_from_params, project
from graphpose.pose.gauss_newton import gauss_newton
from graphpose.pose.graph import graph_pose
from graphpose.track.results import FrameResult
from tests.conftest import BOARD_WPTS as WPTS
from tests.conftest import PROJECT_K as K

T = T_from_params([0.2, 0.15, -1.0, 0.05, -0.03, 0.1])
I = project(K, T, WPTS) + np.random.default_rng(0).normal(0, 0.2, (2, WPTS.shape[1]))


def _old(obj, name):
    with pytest.warns(DeprecationWarning, match=name):
        return getattr(obj, name)


def test_renamed_result_fields_give_the_new_ones_values():
    gn = gauss_newton(I, WPTS, K, guess=T)
    assert _old(gn, "residual_rms_px") == gn.rms_px
    graph = graph_pose(I, WPTS, K, guess=gn.T_WC)
    assert _old(graph, "residual_rms_px") == graph.rms_px
    # The old names keep their old units (mm, degrees); the new ones are SI.
    np.testing.assert_array_equal(_old(graph, "sigma_translation_mm"), 1e3 * graph.sigma_translation_m)
    np.testing.assert_array_equal(_old(graph, "sigma_rotation_deg"), np.degrees(graph.sigma_rotation_rad))
    estimate = estimate_pose_from_points(I, WPTS, K)
    assert _old(estimate, "reprojection_rms_px") == estimate.rms_px == estimate.gn.rms_px
    frame = FrameResult(0, 0.0, "tracked", rms_px=0.5)
    assert _old(frame, "reprojection_rms_px") == 0.5


def test_the_calibration_cross_check_still_reads_as_the_mapping_it_was():
    check = SolverCrossCheck(gtsam=[1.0], lm=[1.0 + 1e-9], max_difference=1e-9, tolerance=1e-6,
                             gtsam_converged=True, lm_converged=False)
    with pytest.warns(DeprecationWarning, match="SolverCrossCheck"):
        assert check["max_difference"] == 1e-9 and check["converged"] == {"gtsam": True, "lm": False}


@pytest.mark.parametrize("module", ["graphpose.pipeline", "graphpose.pose.estimate"])
def test_the_old_module_names_forward_to_graphpose_estimate(module):
    import importlib

    import graphpose.estimate

    old = importlib.import_module(module)
    with pytest.warns(DeprecationWarning, match="graphpose.estimate"):
        assert old.estimate_pose_from_points is graphpose.estimate.estimate_pose_from_points
    with pytest.raises(AttributeError):
        old.no_such_name  # noqa: B018


def test_calibrate_ignores_an_rng_with_a_warning():
    from graphpose.calibrate import calibrate
    from graphpose.errors import InputError

    with pytest.warns(DeprecationWarning, match="rng"), pytest.raises(InputError):
        calibrate([], rng=0)  # the warning, then the refusal of no images, as without rng
