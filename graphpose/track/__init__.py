"""Pose over image sequences: settings (:mod:`.config`), results (:mod:`.results`), frames
and timestamps (:mod:`.frames`), the front end on junctions (:mod:`.frontend`), the back end
(the interface :mod:`.backend`, the fixed lag :mod:`.fixed_lag` and the whole sequence
:mod:`.sequence_graph` on the iSAM2 settings of :mod:`.isam`), its factor model
(:mod:`.model`, :mod:`.factors`) and the batch smoothing (:mod:`.smoothing`), tied together
by :func:`graphpose.track.tracker.track_sequence`."""
