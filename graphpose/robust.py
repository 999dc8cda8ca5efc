"""The robust-estimation rules every solver shares: the Huber threshold and the pixel noise
read off residuals by their median absolute value.

The pose (Gauss-Newton and the factor graph), the rig's pose and the calibration all weigh
their residuals with a Huber kernel at :data:`HUBER_K` sigmas, the sigma taken from an
earlier fit's residuals by :func:`mad_sigma`; both live here so that one number serves them.
"""

from __future__ import annotations

import numpy as np

#: Huber threshold, in units of the pixel sigma: the kernel's 95 % efficiency under Gaussian
#: noise (Huber's constant).
HUBER_K = 1.345
#: The median absolute value of a zero-mean Gaussian sample, times this, estimates its sigma
#: (1 / 0.6745, the inverse normal's 75th percentile, to four decimals).
MAD_TO_SIGMA = 1.4826


def mad_sigma(residuals, *, floor: float) -> float:
    """The pixel noise of residuals: 1.4826 x their median absolute coordinate, at least ``floor``.

    A few gross outliers leave the median where the majority puts it, so this is the sigma a
    Huber kernel (:data:`HUBER_K`) is scaled by after a first fit.

    Parameters
    ----------
    residuals : (2, m) ndarray, or a sequence of (2, m_i) ndarrays
        Measured minus predicted pixels (u, v) of the used points, finite; a sequence is
        taken as one (stacked side by side).
    floor : float
        The smallest sigma returned, pixels: a fit to rendered points leaves residuals of
        almost nothing, and a Huber threshold of zero would weigh every point down. The
        pose's solvers use 1e-12, the calibration's and the rig's 1e-6.

    Returns
    -------
    float
        Pixels; NaN when ``residuals`` hold no number (a NaN in them makes it NaN too).
    """
    r = np.hstack(residuals) if isinstance(residuals, (list, tuple)) else residuals
    return max(MAD_TO_SIGMA * float(np.median(np.abs(r))), floor)
