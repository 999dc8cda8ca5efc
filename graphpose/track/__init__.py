"""Pose over image sequences: settings (:mod:`.config`), results (:mod:`.results`), frames
and timestamps (:mod:`.frames`), the front end on junctions (:mod:`.frontend`), the iSAM2
back end and its factors (:mod:`.backend`, :mod:`.factors`), tied together by
:func:`graphpose.track.tracker.track_sequence`."""
