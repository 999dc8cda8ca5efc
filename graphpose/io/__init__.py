"""Files: case files (:mod:`.cases`), TUM trajectories (:mod:`.tum`), and JSON/PNG written
whole or not at all (:mod:`.files`). Images are read by :mod:`graphpose.image`."""
