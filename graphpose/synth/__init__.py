"""Synthetic images with exact truth: single renders (:mod:`.render`), renders through a camera's
imperfections (:mod:`.degrade`: noise, blur, low light, JPEG, vignetting) and hand-held
sequences (:mod:`.sequence`)."""

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
