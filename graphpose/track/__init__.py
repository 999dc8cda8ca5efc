"""Pose over image sequences: settings (:mod:`.config`), results (:mod:`.results`), frames
and timestamps (:mod:`.frames`), the front end on junctions (:mod:`.frontend`), the back end
(the interface :mod:`.backend`, the fixed lag :mod:`.fixed_lag` and the whole sequence
:mod:`.sequence_graph` on the iSAM2 settings of :mod:`.isam`), its factor model
(:mod:`.model`, :mod:`.factors`) and the batch smoothing (:mod:`.smoothing`), tied together
by :func:`graphpose.track.tracker.track_frames` (a stream of frame results) and
:func:`graphpose.track.tracker.track_sequence` (all of them at once), with the calibration's
uncertainty carried into the poses by :mod:`.uncertainty`."""

from .._lazy import lazy_getattr

__all__ = ["track_frames", "track_sequence"]

# Lazy, as the top-level package is: importing graphpose.track.config (the command line's
# options) must not load GTSAM and the detector.
__getattr__ = lazy_getattr(__name__, {name: "tracker" for name in __all__})
