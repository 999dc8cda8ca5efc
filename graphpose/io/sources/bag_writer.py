"""ROS bags written with ``rosbags``' writers, from grey frames: for tests, the benchmark and
users who want to try graphpose's bag reader on their own frames.

:func:`write_bag` writes a ROS 1 ``.bag``, or a ROS 2 bag (sqlite3 or mcap), holding one
image topic (``sensor_msgs/Image`` mono8, or ``sensor_msgs/CompressedImage`` PNG) and, with a
camera, a ``camera_info`` beside it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError

#: Bag formats :func:`write_bag` writes.
BAG_FORMATS = ("ros1", "ros2-sqlite3", "ros2-mcap")


def write_bag(path, images, timestamps, *, fmt: str = "ros2-sqlite3", topic: str = "/camera/image_raw",
              compressed: bool = False, camera=None, frame_id: str = "camera") -> Path:
    """Write grey frames into a new bag.

    Parameters
    ----------
    path : str or Path
        A ``.bag`` file (``ros1``) or the bag's folder (ROS 2), not existing yet.
    images : iterable of (H, W) ndarray of uint8
        The frames.
    timestamps : (N,) array_like
        Header stamps (and receive times), seconds.
    fmt : str
        One of :data:`BAG_FORMATS`.
    topic : str
        The image topic; ``compressed`` adds ``/compressed`` to it, as image_transport does.
    compressed : bool
        PNG ``CompressedImage`` messages instead of mono8 ``Image``.
    camera : Camera, optional
        Written as one ``CameraInfo`` on ``<namespace>/camera_info`` (pinhole or radtan:
        ``plumb_bob``).
    frame_id : str
        The headers' frame id.

    Returns
    -------
    Path
        The bag (file or folder) to read.
    """
    from rosbags.typesys import Stores, get_typestore

    if fmt not in BAG_FORMATS:
        raise InputError(f"fmt must be one of {', '.join(BAG_FORMATS)}, got {fmt!r}")
    path = Path(path)
    ros1 = fmt == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    image_topic = topic + "/compressed" if compressed else topic
    info_topic = topic.rsplit("/", 1)[0] + "/camera_info"
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    kind = "sensor_msgs/msg/CompressedImage" if compressed else "sensor_msgs/msg/Image"
    with _writer(path, fmt) as writer:
        conn = writer.add_connection(image_topic, kind, typestore=store)
        t = np.asarray(timestamps, dtype=float)
        first = True
        for k, image in enumerate(images):
            ns = int(round(t[k] * 1e9))
            stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            header = (Header(seq=k, stamp=stamp, frame_id=frame_id) if ros1
                      else Header(stamp=stamp, frame_id=frame_id))
            if first and camera is not None:
                info_conn = writer.add_connection(info_topic, "sensor_msgs/msg/CameraInfo", typestore=store)
                writer.write(info_conn, ns, serialize(_camera_info(store, header, camera, image.shape, ros1),
                                                      "sensor_msgs/msg/CameraInfo"))
            first = False
            msg = _image_msg(store, header, np.asarray(image, dtype=np.uint8), compressed)
            writer.write(conn, ns, serialize(msg, kind))
    return path


class _writer:
    def __init__(self, path, fmt):
        if fmt == "ros1":
            from rosbags.rosbag1 import Writer

            self.w = Writer(path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            plugin = StoragePlugin.MCAP if fmt == "ros2-mcap" else StoragePlugin.SQLITE3
            self.w = Writer(path, version=9, storage_plugin=plugin)

    def __enter__(self):
        self.w.open()
        return self.w

    def __exit__(self, *exc):
        self.w.close()


def _image_msg(store, header, image, compressed):
    if compressed:
        from ..files import encode_png

        data = np.frombuffer(encode_png(image), dtype=np.uint8)
        return store.types["sensor_msgs/msg/CompressedImage"](header=header, format="mono8; png compressed ",
                                                                data=data)
    h, w = image.shape
    return store.types["sensor_msgs/msg/Image"](header=header, height=h, width=w, encoding="mono8", is_bigendian=0,
                                                step=w, data=np.ascontiguousarray(image).reshape(-1))


def _camera_info(store, header, camera, shape, ros1):
    K = np.asarray(camera.K, dtype=float)
    d = np.asarray(getattr(camera, "distortion", np.zeros(0)), dtype=float).reshape(-1)
    if d.size == 0:
        d = np.zeros(5)
    P = np.hstack([K, np.zeros((3, 1))]).reshape(-1)
    Roi = store.types["sensor_msgs/msg/RegionOfInterest"]
    fields = dict(header=header, height=shape[0], width=shape[1], distortion_model="plumb_bob",
                  binning_x=0, binning_y=0, roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
    names = ("D", "K", "R", "P") if ros1 else ("d", "k", "r", "p")
    fields.update(zip(names, (d, K.reshape(-1), np.eye(3).reshape(-1), P)))
    return store.types["sensor_msgs/msg/CameraInfo"](**fields)
