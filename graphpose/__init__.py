"""graphpose: where a calibrated camera is, relative to a planar checkerboard target.

Data flows one way: image -> cross-junctions (:mod:`graphpose.junctions`, refined by
:mod:`graphpose.saddle`) -> pose by Gauss-Newton (:mod:`graphpose.gauss_newton`) and by a
GTSAM factor graph (:mod:`graphpose.graph`), held against each other by
:mod:`graphpose.pipeline` -> result; over image sequences, :mod:`graphpose.tracking` with
iSAM2. :mod:`graphpose.render` makes synthetic images with exact truth. Conventions are
stated once, in :mod:`graphpose.camera`.
"""

from .board import Board
from .camera import (
    C_from_rpy,
    K_from_params,
    T_from_params,
    check_K,
    check_transform,
    params_from_T,
    project,
    rpy_from_C,
)
from .errors import (
    BoardNotFoundError,
    ConvergenceError,
    GraphposeError,
    InputError,
    SaddleError,
)
from .io import as_grey, load_cases, read_image

from .saddle import SaddleFit, fit_saddles, saddle_point
from .gauss_newton import GNResult, find_jacobian, gauss_newton, pose_estimate_nls
from .homography import pose_from_homography
from .junctions import Junctions, cross_junctions, extract_junctions, refine_junctions
from .graph import GraphResult, graph_pose
from .pipeline import CrossCheck, PoseEstimate, estimate_pose, estimate_pose_from_points
from .tum import TumTrajectory, read_tum, write_tum
from .tracking import FrameResult, MotionPrior, Track, TrackerConfig, track_sequence
from .sequence import Sequence, render_sequence, write_sequence

__all__ = [
    "as_grey",
    "Board",
    "BoardNotFoundError",
    "C_from_rpy",
    "check_K",
    "check_transform",
    "ConvergenceError",
    "cross_junctions",
    "CrossCheck",
    "estimate_pose",
    "estimate_pose_from_points",
    "extract_junctions",
    "find_jacobian",
    "fit_saddles",
    "FrameResult",
    "gauss_newton",
    "GNResult",
    "graph_pose",
    "GraphposeError",
    "GraphResult",
    "InputError",
    "Junctions",
    "K_from_params",
    "load_cases",
    "MotionPrior",
    "params_from_T",
    "pose_estimate_nls",
    "pose_from_homography",
    "PoseEstimate",
    "project",
    "read_image",
    "read_tum",
    "refine_junctions",
    "render_sequence",
    "rpy_from_C",
    "saddle_point",
    "SaddleError",
    "SaddleFit",
    "Sequence",
    "T_from_params",
    "Track",
    "track_sequence",
    "TrackerConfig",
    "TumTrajectory",
    "write_sequence",
    "write_tum",
]
