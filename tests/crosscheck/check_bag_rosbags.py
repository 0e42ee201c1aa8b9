"""Bags written by `rosbags` (PyPI), a common way to write ROS 2 bags without ROS.

  write DIR STORE EXPECT.jsonl   rosbag2 directory (metadata.yaml + MCAP) with CameraInfo,
                                 TFMessage, a 32FC1 depth Image and JointState, typed from the
                                 rosbags type store STORE (ros2_humble, ros2_jazzy); the values
                                 written go to EXPECT.jsonl for `check_bag.py compare`
  read-dir DIR                   a rosbag2 directory written by `cowork bag record -o DIR`:
                                 rosbags opens it from its metadata.yaml; per topic, the count
                                 metadata.yaml gives equals the messages rosbags reads and the
                                 messages the `mcap` package reads from the storage file; every
                                 message of a type rosbags' ros2_humble store knows deserialises
  write-bad FILE.mcap            one CameraInfo whose RegionOfInterest lacks `do_rectify` (a
                                 layout that is not ours): cowork must refuse it, naming the field

rosbags spells nested types in full (`sensor_msgs/RegionOfInterest roi`) and leaves out the
default values of our .msg texts; cowork compares layouts, not texts, so these must decode.
"""

import json
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.msg import get_types_from_msg

W, H = 8, 6


def plain(x):
    """A message as JSON-able values (what bag_to_json prints)."""
    if hasattr(x, "__dataclass_fields__"):
        return {k: plain(getattr(x, k)) for k in x.__dataclass_fields__ if k != "__msgtype__"}
    if isinstance(x, np.ndarray):
        if x.dtype == np.uint8:
            return list(bytes(x))
        return [plain(v) for v in x.tolist()]
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    return x


def write(directory, store, expect):
    ts = get_typestore(Stores(store))
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    rows = []
    with Writer(Path(directory), version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {
            "/camera/depth/camera_info": writer.add_connection("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts),
            "/camera/depth/image_raw": writer.add_connection("/camera/depth/image_raw", "sensor_msgs/msg/Image", typestore=ts),
            "/tf": writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=ts),
            "/joint_states": writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts),
        }

        def put(topic, t, msg):
            conn = conns[topic]
            writer.write(conn, t, ts.serialize_cdr(msg, conn.msgtype))
            rows.append({"topic": topic, "type": conn.msgtype, "log_time_ns": t, "publish_time_ns": t, "msg": plain(msg)})

        for k in range(6):
            t = 2_000_000_000 + k * 33_333_333
            hdr = Header(stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id="camera_depth_optical_frame")
            roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=k, y_offset=1, height=2, width=3, do_rectify=k % 2 == 0)
            # The arm's joint state first: a depth frame is computed at the joint state of its time.
            put("/joint_states", t, T["sensor_msgs/msg/JointState"](
                header=Header(stamp=hdr.stamp, frame_id=""), name=[f"lwr_joint_{j}" for j in range(1, 8)],
                position=np.array([0.1 * k - 0.3 * j for j in range(7)]), velocity=np.array([1e-3 * j * k for j in range(7)]),
                effort=np.array([], dtype=np.float64)))
            put("/camera/depth/camera_info", t + 1, T["sensor_msgs/msg/CameraInfo"](
                header=hdr, height=H, width=W, distortion_model="plumb_bob",
                d=np.array([0.1, -0.01, 0.0, 0.0, 0.001 * k]),
                k=np.array([525.0, 0, 3.5, 0, 525.0, 2.5, 0, 0, 1]),
                r=np.array([1.0, 0, 0, 0, 1, 0, 0, 0, 1]),
                p=np.array([525.0, 0, 3.5, 0, 0, 525.0, 2.5, 0, 0, 0, 1, 0]),
                binning_x=0, binning_y=0, roi=roi))
            depth = (0.5 + 0.01 * np.arange(W * H, dtype=np.float32) + 0.25 * k).astype("<f4")
            put("/camera/depth/image_raw", t + 3, T["sensor_msgs/msg/Image"](
                header=hdr, height=H, width=W, encoding="32FC1", is_bigendian=0, step=W * 4,
                data=np.frombuffer(depth.tobytes(), dtype=np.uint8)))
            tf = T["geometry_msgs/msg/TransformStamped"](
                # The camera in the base frame (optical z along base -x, looking at the arm).
                header=Header(stamp=hdr.stamp, frame_id="lwr_base_link"), child_frame_id="camera_depth_optical_frame",
                transform=T["geometry_msgs/msg/Transform"](
                    translation=T["geometry_msgs/msg/Vector3"](x=1.9 + 0.01 * k, y=0.0, z=0.5),
                    rotation=T["geometry_msgs/msg/Quaternion"](x=0.5, y=-0.5, z=0.5, w=-0.5)))
            put("/tf", t + 2, T["tf2_msgs/msg/TFMessage"](transforms=[tf]))
    rows.sort(key=lambda r: r["log_time_ns"])  # the order a reader yields them
    with open(expect, "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
    print(f"rosbags ({store}) wrote {len(rows)} messages to the rosbag2 directory {directory}")


# RegionOfInterest without do_rectify: a different layout under the same type name.
BAD_ROI = """uint32 x_offset
uint32 y_offset
uint32 height
uint32 width
"""


def write_bad(path):
    ts = get_typestore(Stores.EMPTY)
    ts.register(get_types_from_msg(BAD_ROI, "sensor_msgs/msg/RegionOfInterest"))
    humble = get_typestore(Stores.ROS2_HUMBLE)
    for name in ["builtin_interfaces/msg/Time", "std_msgs/msg/Header"]:
        ts.register({name: humble.fielddefs[name]})
    info_def = "\n".join(
        ["std_msgs/Header header", "uint32 height", "uint32 width", "string distortion_model", "float64[] d",
         "float64[9] k", "float64[9] r", "float64[12] p", "uint32 binning_x", "uint32 binning_y",
         "sensor_msgs/RegionOfInterest roi"])
    ts.register(get_types_from_msg(info_def, "sensor_msgs/msg/CameraInfo"))
    T = ts.types
    out = Path(path)
    with Writer(out, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
        hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="cam")
        msg = T["sensor_msgs/msg/CameraInfo"](
            header=hdr, height=H, width=W, distortion_model="plumb_bob", d=np.zeros(5), k=np.zeros(9),
            r=np.zeros(9), p=np.zeros(12), binning_x=0, binning_y=0,
            roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0))
        writer.write(conn, 1_000_000_000, ts.serialize_cdr(msg, conn.msgtype))
    print(f"rosbags wrote a CameraInfo with a different RegionOfInterest layout to {out}")


def read_dir(directory):
    from collections import Counter

    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader

    ts = get_typestore(Stores.ROS2_HUMBLE)
    read, decoded = Counter(), 0
    with Reader(directory) as reader:
        listed = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
        for conn, _t, raw in reader.messages():
            read[conn.topic] += 1
            if conn.msgtype in ts.types:
                ts.deserialize_cdr(raw, conn.msgtype)
                decoded += 1
    storage = sorted(Path(directory).glob("*.mcap"))
    assert len(storage) == 1, storage
    with open(storage[0], "rb") as f:
        direct = Counter(ch.topic for _s, ch, _m in make_reader(f).iter_messages())
    assert listed, "metadata.yaml lists no topic"
    for topic, n in sorted(listed.items()):
        assert read[topic] == n, f"{topic}: metadata.yaml says {n}, rosbags read {read[topic]}"
        assert direct[topic] == n, f"{topic}: metadata.yaml says {n}, the mcap package read {direct[topic]}"
    assert set(direct) == set(listed), f"topics in the file but not in metadata.yaml: {set(direct) - set(listed)}"
    print(f"  rosbags read the cowork rosbag2 directory: {sum(read.values())} messages on {len(listed)} topics "
          f"({', '.join(f'{t} {types[t]} {n}' for t, n in sorted(listed.items()))}), "
          f"{decoded} deserialised by rosbags' ros2_humble store; counts equal metadata.yaml and the mcap package")


def main():
    mode = sys.argv[1]
    if mode == "write":
        write(sys.argv[2], sys.argv[3], sys.argv[4])
    elif mode == "read-dir":
        read_dir(sys.argv[2])
    elif mode == "write-bad":
        write_bad(sys.argv[2])
    else:
        sys.exit(f"unknown mode {mode!r}")


if __name__ == "__main__":
    main()
