"""Junctions -> pose: the homography start (:mod:`.homography`), Gauss-Newton with an
analytic Jacobian (:mod:`.gauss_newton`), the GTSAM factor graph (:mod:`.graph`, the only
module here that imports GTSAM), the two held against each other (:mod:`.cross_check`), and
the calibration's uncertainty carried into the pose (:mod:`.covariance`). The chain that runs
both solvers is :mod:`graphpose.estimate`, beside the image-to-pose one."""
