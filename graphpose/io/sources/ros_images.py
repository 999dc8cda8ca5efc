"""ROS image messages to grey pixels, and a ``camera_info`` message to a camera.

``sensor_msgs/Image`` in ``mono8``/``8UC1``, ``mono16``/``16UC1`` (kept 16-bit), ``rgb8``,
``bgr8``, ``rgba8``, ``bgra8`` (ITU-R 601 luma in integers, as :func:`graphpose.image.read_image`
makes it) and the Bayer encodings ``bayer_rggb8``, ``bayer_bggr8``, ``bayer_gbrg8``,
``bayer_grbg8`` (and their 16-bit forms): a Bayer mosaic is made grey by the 3 x 3 binomial
filter ``[1 2 1]^T [1 2 1] / 16``, which at every pixel, whatever the pattern's phase, weighs
red 1/4, green 1/2 and blue 1/4 and is centred on the pixel (no half-pixel shift, so the
camera's calibration still holds). ``sensor_msgs/CompressedImage`` in JPEG or PNG (``format``
names it, e.g. ``"jpeg"``, ``"rgb8; png compressed bgr8"``), decoded by Pillow to grey.
Anything else (``yuv422``, float depth images, ``compressedDepth``) is refused by name.
"""

from __future__ import annotations

import io

import numpy as np

from ...errors import InputError

#: ``sensor_msgs/Image`` encodings graphpose reads, as the message names them.
IMAGE_ENCODINGS = ("mono8", "8UC1", "mono16", "16UC1", "rgb8", "bgr8", "rgba8", "bgra8",
                   "bayer_rggb8", "bayer_bggr8", "bayer_gbrg8", "bayer_grbg8",
                   "bayer_rggb16", "bayer_bggr16", "bayer_gbrg16", "bayer_grbg16")
#: ``sensor_msgs/CompressedImage`` formats graphpose reads.
COMPRESSED_FORMATS = ("jpeg", "png")

#: Channel order of the colour encodings: index of R, G, B.
_COLOUR = {"rgb8": (0, 1, 2, 3), "bgr8": (2, 1, 0, 3), "rgba8": (0, 1, 2, 4), "bgra8": (2, 1, 0, 4)}


def check_encoding(msg, topic: str) -> None:
    """InputError naming the encoding when ``msg`` (an Image or CompressedImage) is not one
    graphpose reads; the message lists those it does."""
    if hasattr(msg, "encoding"):
        if msg.encoding not in IMAGE_ENCODINGS:
            raise InputError(f"topic {topic}: image encoding {msg.encoding!r} is not one graphpose reads "
                             f"({', '.join(IMAGE_ENCODINGS)})")
    elif _compressed_kind(msg.format) is None:
        raise InputError(f"topic {topic}: compressed image format {msg.format!r} is not one graphpose reads "
                         f"(JPEG or PNG)")


def image_grey(msg) -> np.ndarray:
    """A ``sensor_msgs/Image`` as grey, (H, W): uint8, or uint16 for the 16-bit encodings.

    Raises
    ------
    InputError
        If the encoding is not one of :data:`IMAGE_ENCODINGS` or the data is shorter than
        ``height * step`` bytes.
    """
    enc, h, w, step = msg.encoding, int(msg.height), int(msg.width), int(msg.step)
    data = np.asarray(msg.data, dtype=np.uint8)
    if enc not in IMAGE_ENCODINGS:
        raise InputError(f"image encoding {enc!r} is not one graphpose reads ({', '.join(IMAGE_ENCODINGS)})")
    if data.size < h * step or h == 0 or w == 0:
        raise InputError(f"image message of {w} x {h} pixels, step {step}, holds only {data.size} bytes")
    rows = data[: h * step].reshape(h, step)
    if enc in ("mono8", "8UC1"):
        return np.ascontiguousarray(rows[:, :w])
    if enc in ("mono16", "16UC1") or enc.endswith("16"):
        order = ">" if msg.is_bigendian else "<"
        grey16 = np.ascontiguousarray(rows[:, : 2 * w]).view(f"{order}u2").astype(np.uint16)
        return _bayer_grey(grey16) if enc.startswith("bayer") else grey16
    if enc.startswith("bayer"):
        return _bayer_grey(np.ascontiguousarray(rows[:, :w]))
    r, g, b, c = _COLOUR[enc]
    px = rows[:, : c * w].reshape(h, w, c).astype(np.uint32)
    return ((299 * px[..., r] + 587 * px[..., g] + 114 * px[..., b] + 500) // 1000).astype(np.uint8)


def compressed_grey(msg) -> np.ndarray:
    """A ``sensor_msgs/CompressedImage`` (JPEG or PNG) as grey, (H, W): uint8 (uint16 for a 16-bit
    grey PNG).

    Raises
    ------
    InputError
        If the format is not JPEG or PNG, or the bytes cannot be decoded.
    """
    from PIL import Image, UnidentifiedImageError

    if _compressed_kind(msg.format) is None:
        raise InputError(f"compressed image format {msg.format!r} is not one graphpose reads (JPEG or PNG)")
    try:
        with Image.open(io.BytesIO(np.asarray(msg.data, dtype=np.uint8).tobytes())) as im:
            if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                return np.asarray(im, dtype=np.uint16)
            if im.mode == "L":
                return np.asarray(im)
            if im.format == "JPEG":
                im.draft("L", im.size)  # the decoder's own luma plane, as read_image reads a JPEG
            return np.asarray(im.convert("L"))
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise InputError(f"compressed image ({msg.format}) cannot be decoded: {exc}") from None


def message_grey(msg) -> np.ndarray:
    """An Image or a CompressedImage message as grey (:func:`image_grey`, :func:`compressed_grey`)."""
    return image_grey(msg) if hasattr(msg, "encoding") else compressed_grey(msg)


def camera_info_camera(msg, what: str):
    """The camera of a ``sensor_msgs/CameraInfo`` message (ROS 1 or ROS 2 field names).

    Parameters
    ----------
    msg : CameraInfo
        ``K`` (or ``k``), ``D`` (``d``), ``distortion_model``, ``width``, ``height``.
    what : str
        The message's origin (bag and topic) for errors.

    Raises
    ------
    InputError
        As :func:`graphpose.io.cameras.camera_from_ros_info` (an unknown distortion model,
        a K of zeros: a camera_info of an uncalibrated camera).
    """
    from ..cameras import camera_from_ros_info

    K = np.asarray(getattr(msg, "k", getattr(msg, "K", None)), dtype=float).reshape(-1)
    d = np.asarray(getattr(msg, "d", getattr(msg, "D", [])), dtype=float).reshape(-1)
    if K.size != 9 or not np.any(K):
        raise InputError(f"{what}: the camera_info's K is empty (the camera was not calibrated)")
    if not np.any(d):  # all zero: a camera without distortion, as ROS's own tools read it
        d = d[:0]
    doc = {"camera_matrix": K.tolist(), "distortion_model": msg.distortion_model or "plumb_bob",
           "distortion_coefficients": d.tolist(), "image_width": int(msg.width), "image_height": int(msg.height)}
    return camera_from_ros_info(doc, what)


def _compressed_kind(fmt: str):
    text = str(fmt).lower()
    if "compresseddepth" in text:
        return None
    for kind in COMPRESSED_FORMATS:
        if kind in text or (kind == "jpeg" and "jpg" in text):
            return kind
    return None


def _bayer_grey(mosaic: np.ndarray) -> np.ndarray:
    """The binomial 3 x 3 average of a Bayer mosaic (see the module docstring), edges mirrored."""
    a = np.pad(mosaic.astype(np.uint32), 1, mode="reflect")
    rows = a[:-2] + 2 * a[1:-1] + a[2:]
    grey = (rows[:, :-2] + 2 * rows[:, 1:-1] + rows[:, 2:] + 8) // 16
    return grey.astype(mosaic.dtype)
