"""ROS bags through ``rosbags`` (pure Python): ROS 1 ``.bag`` files and ROS 2 bags (sqlite3 or mcap).

One image topic is read (``topic``; a bag with one image topic needs none): ``sensor_msgs/Image``
or ``sensor_msgs/CompressedImage`` (:mod:`graphpose.io.sources.ros_images`). The index pass reads
each message's header stamp from its first bytes (no image is decoded): the frame's timestamp
is the header's, as the camera driver stamped it. A ``sensor_msgs/CameraInfo`` beside the topic
(``/cam/camera_info`` for ``/cam/image_raw`` or ``/cam/image_raw/compressed``) is the
recording's :attr:`~graphpose.io.sources.base.Recording.camera`.

A ROS 2 bag is its folder (the one with ``metadata.yaml``); naming its ``.db3`` or ``.mcap``
file, or its ``metadata.yaml``, means the folder.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from ...errors import InputError
from .base import BrokenRecordingError, Frame, Recording
from .ros_images import camera_info_camera, check_encoding, message_grey

#: Message types read as frames (rosbags' names, the same for ROS 1 and ROS 2).
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
#: File name endings of bags (a ROS 2 bag is also recognised as a folder with metadata.yaml).
BAG_SUFFIXES = (".bag", ".db3", ".mcap")


def is_bag(path) -> bool:
    """True for a ROS 1 ``.bag`` file, a ROS 2 bag folder or one of its files."""
    path = Path(path)
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.suffix.lower() in BAG_SUFFIXES or (path.name == "metadata.yaml" and path.is_file())


class BagRecording(Recording):
    """The frames of one image topic of a ROS bag (see the module docstring).

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag`` file, or a ROS 2 bag's folder (or a file in it).
    topic : str, optional
        The image topic; may be left out when the bag has exactly one.

    Raises
    ------
    InputError
        If the bag is missing or unreadable; the topic is not in it or not an image topic,
        or no topic is given and the bag has several (each message lists the bag's image
        topics with their types and counts); the topic has no message; its encoding is not
        one graphpose reads; or its camera_info is unusable.
    """

    def __init__(self, path, topic: str | None = None):
        self.bag = _bag_path(Path(path))
        reader = _open_reader(self.bag)
        try:
            self.kind = "ROS 2 bag" if reader.is2 else "ROS 1 bag"
            self.topic, self.msgtype = _choose_topic(reader, self.bag, topic)
            conns = [c for c in reader.connections if c.topic == self.topic]
            stamps, self.receive_ns, first = _index(reader, conns, reader.is2)
            if not stamps:
                raise InputError(f"{self.bag}: topic {self.topic} holds no message")
            check_encoding(reader.deserialize(first, self.msgtype), self.topic)
            self.camera, self.camera_source = _camera_info(reader, self.bag, self.topic)
        finally:
            reader.close()
        super().__init__(str(path), stamps)

    def label(self, k: int) -> str:
        return f"{self.name}:{self.topic}#{k}"

    def _open_at(self, k: int):
        return _messages(self, k)


def _bag_path(path: Path) -> Path:
    if not path.exists():
        raise InputError(f"bag not found: {path}")
    if path.is_file() and path.suffix.lower() in (".db3", ".mcap") or path.name == "metadata.yaml":
        if not (path.parent / "metadata.yaml").is_file():
            raise InputError(f"{path}: a ROS 2 bag is read from its folder, and {path.parent} has no metadata.yaml")
        return path.parent
    return path


def _open_reader(bag: Path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    # A ROS 2 bag without its message definitions is read with the latest ROS 2 types.
    reader = AnyReader([bag], default_typestore=get_typestore(Stores.LATEST))
    try:
        reader.open()
    except Exception as exc:  # rosbags raises its own errors, and OSError, for a broken bag
        raise InputError(f"{bag}: not a ROS bag rosbags can read ({' '.join(str(exc).split())})") from None
    return reader


def _image_topics(reader) -> str:
    """The bag's image topics as ``/a (sensor_msgs/msg/Image, 300 messages), ...`` or "none"."""
    seen = {}
    for c in reader.connections:
        if c.msgtype in IMAGE_TYPES:
            seen.setdefault(c.topic, [c.msgtype, 0])[1] += c.msgcount
    return ", ".join(f"{t} ({m}, {n} messages)" for t, (m, n) in sorted(seen.items())) or "none"


def _choose_topic(reader, bag, topic):
    topics = {c.topic: c.msgtype for c in reader.connections}
    images = sorted(t for t, m in topics.items() if m in IMAGE_TYPES)
    if topic is None:
        if len(images) == 1:
            return images[0], topics[images[0]]
        what = "holds no image topic" if not images else "holds several image topics"
        raise InputError(f"{bag} {what}; give one with --topic: image topics: {_image_topics(reader)}")
    if topic not in topics:
        raise InputError(f"{bag} has no topic {topic}; its image topics: {_image_topics(reader)}")
    if topics[topic] not in IMAGE_TYPES:
        raise InputError(f"{bag}: topic {topic} is {topics[topic]}, not an image; its image topics: "
                         f"{_image_topics(reader)}")
    return topic, topics[topic]


def _index(reader, conns, is2: bool):
    """The header stamps (seconds) and receive times (ns) of the topic's messages, in the bag's
    order, from their first bytes; and the first message's bytes."""
    stamps, receive, first = [], [], None
    for _, t_ns, raw in reader.messages(connections=conns):
        stamps.append(_stamp(raw, is2))
        receive.append(t_ns)
        if first is None:
            first = raw
    return stamps, np.array(receive, dtype=np.int64), first


def _stamp(raw, is2: bool) -> float:
    """A message's ``header.stamp`` in seconds, from its serialised bytes: ROS 1 (seq, secs,
    nsecs: three little-endian uint32) or CDR (4 bytes of encapsulation, then sec int32,
    nanosec uint32, in the byte order it names)."""
    if is2:
        order = "<" if raw[1] & 1 else ">"
        sec, nsec = struct.unpack_from(order + "iI", raw, 4)
    else:
        sec, nsec = struct.unpack_from("<II", raw, 4)
    return sec + nsec * 1e-9


def _camera_info(reader, bag, topic):
    """``(camera, where)`` from the camera_info beside ``topic`` (the nearest namespace up), or
    (None, "")."""
    infos = {c.topic: c for c in reader.connections if c.msgtype == CAMERA_INFO}
    parts = topic.rstrip("/").split("/")
    for n in range(len(parts), 0, -1):
        name = "/".join(parts[:n]) + "/camera_info"
        if name in infos:
            for conn, _, raw in reader.messages(connections=[infos[name]]):
                what = f"{bag}:{name}"
                return camera_info_camera(reader.deserialize(raw, conn.msgtype), what), what
    return None, ""


def _messages(bag: BagRecording, k: int):
    """Frames from ``k`` on: the reader started at frame k's receive time."""
    reader = _open_reader(bag.bag)
    try:
        conns = [c for c in reader.connections if c.topic == bag.topic]
        start = int(bag.receive_ns[k])
        skip = int(np.sum(bag.receive_ns[:k] == start))  # earlier frames received at the same ns
        index = k - skip
        for conn, _, raw in reader.messages(connections=conns, start=start):
            if index < k:
                index += 1
                continue
            if index >= len(bag):
                break
            try:
                image = message_grey(reader.deserialize(raw, conn.msgtype))
            except InputError as exc:
                t = float(bag.timestamps[index])
                raise BrokenRecordingError(f"{bag.label(index)} (t = {t:.3f} s): {exc}", index, t) from None
            yield Frame(index, float(bag.timestamps[index]), image)
            index += 1
    finally:
        reader.close()
