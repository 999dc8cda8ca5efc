"""Junctions -> pose: the homography start (:mod:`.homography`), Gauss-Newton with an
analytic Jacobian (:mod:`.gauss_newton`), the GTSAM factor graph (:mod:`.graph`, the only
module here that imports GTSAM), and the image-to-pose pipeline that runs both solvers and
cross-checks them (:mod:`.estimate`)."""
