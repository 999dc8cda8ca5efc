"""Synthetic images with exact truth: single renders (:mod:`.render`, on the exact areas of
:mod:`.raster`), renders through a camera's imperfections (:mod:`.degrade`: noise, blur, low
light, JPEG, vignetting), random poses and polygons (:mod:`.poses`), the junctions' Cramer-Rao
bound (:mod:`.information`) and hand-held sequences (:mod:`.sequence`)."""

from .degrade import (
    Degradation,
    defocus,
    degrade,
    disc_kernel,
    jpeg_roundtrip,
    motion_blur_ideal,
    quantize,
    render_degraded,
    sensor_noise,
    vignette,
)

__all__ = ["Degradation", "defocus", "degrade", "disc_kernel", "jpeg_roundtrip", "motion_blur_ideal", "quantize",
           "render_degraded", "sensor_noise", "vignette"]
