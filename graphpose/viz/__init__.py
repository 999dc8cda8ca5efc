"""Pictures: the overlay of junctions and pose on an image (:mod:`.overlay`) and the
trajectory plot of a track (:mod:`.plot`, needs the ``plot`` extra)."""
