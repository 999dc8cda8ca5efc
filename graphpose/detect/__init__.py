"""Image -> cross-junctions: coarse grid search (:mod:`.grid`), sub-pixel refinement
(:mod:`.refine`, on the saddle fit of :mod:`.saddle`), and the verdict on which junctions
to trust (:mod:`.junctions`)."""
