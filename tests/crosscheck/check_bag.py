"""cowork_bag against the PyPI `mcap` + `mcap-ros2-support` packages.

  check_bag.py read-ours BAG EXPECT.jsonl   decode a bag written by cowork_bag with
                                            mcap_ros2.reader.read_ros2_messages and compare
                                            every message with what the Rust side wrote
  check_bag.py write-theirs BAG EXPECT.jsonl  write a bag with mcap_ros2.writer.Writer
                                            (depth Image 16UC1 and 32FC1, CameraInfo, JointState)
                                            and the values written
  check_bag.py compare EXPECT.jsonl GOT.jsonl  compare cowork_bag's JSON dump with the values
  check_bag.py compare-prefix EXPECT.jsonl GOT.jsonl  the same for a truncated copy: GOT must be a
                                            non-empty proper prefix of EXPECT

Exits non-zero on any mismatch; prints what it compared.
"""

import json
import struct
import sys

from mcap.reader import make_reader
from mcap_ros2.reader import read_ros2_messages
from mcap_ros2.writer import Writer

# Standard ROS 2 (Jazzy) definitions as a rosbag2 recorder would store them, written here by
# hand (comments trimmed, `pkg/msg/Name` spelling in places) so cowork's schema check sees an
# independent text with the same fields.
TIME = "int32 sec\nuint32 nanosec\n"
HEADER = "# Standard metadata\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
SEP = "=" * 80 + "\n"
IMAGE = (
    "std_msgs/Header header # stamp and optical frame\n"
    "uint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n"
    + SEP + "MSG: std_msgs/Header\n" + HEADER + SEP + "MSG: builtin_interfaces/Time\n" + TIME
)
CAMERA_INFO = (
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n"
    "float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\n"
    "RegionOfInterest roi\n"
    + SEP + "MSG: builtin_interfaces/Time\n" + TIME
    + SEP + "MSG: sensor_msgs/RegionOfInterest\n"
    "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"
    + SEP + "MSG: std_msgs/Header\n" + HEADER
)
JOINT_STATE = (
    "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
    + SEP + "MSG: std_msgs/Header\n" + HEADER + SEP + "MSG: builtin_interfaces/Time\n" + TIME
)


def plain(x):
    """ROS message objects, bytes and tuples -> JSON-comparable values."""
    if isinstance(x, (bytes, bytearray)):
        return list(x)
    if isinstance(x, (list, tuple)):
        return [plain(i) for i in x]
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if hasattr(x, "__slots__"):
        return {s: plain(getattr(x, s)) for s in x.__slots__}
    return x


def diff(a, b, path="msg"):
    """First difference between two JSON values (exact, floats included), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return f"{path}: fields {sorted(a)} != {sorted(b)}"
        for k in a:
            d = diff(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = diff(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if type(a) is bool or type(b) is bool:
        return None if a is b else f"{path}: {a!r} != {b!r}"
    return None if a == b else f"{path}: {a!r} != {b!r}"


def load(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def compare_lists(expected, got, what):
    if len(expected) != len(got):
        sys.exit(f"FAIL {what}: {len(got)} messages, expected {len(expected)}")
    per_topic = {}
    for i, (e, g) in enumerate(zip(expected, got)):
        for key in ("topic", "type", "log_time_ns", "publish_time_ns"):
            if e[key] != g[key]:
                sys.exit(f"FAIL {what} message {i}: {key} {g[key]!r} != {e[key]!r}")
        if "msg" not in g:
            sys.exit(f"FAIL {what} message {i} on {e['topic']}: {g.get('error')}")
        d = diff(e["msg"], g["msg"])
        if d:
            sys.exit(f"FAIL {what} message {i} on {e['topic']} at {e['log_time_ns']} ns: {d}")
        per_topic[e["topic"]] = per_topic.get(e["topic"], 0) + 1
    for topic, n in sorted(per_topic.items()):
        print(f"  {topic:28s} {n:4d} messages equal")
    print(f"{what}: {len(got)} of {len(expected)} messages equal field by field (floats exact)")


def read_ours(bag, expect):
    expected = load(expect)
    with open(bag, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
    if header.profile != "ros2":
        sys.exit(f"FAIL profile {header.profile!r}, expected 'ros2'")
    bad_schema = [s.name for s in summary.schemas.values() if s.encoding != "ros2msg"]
    bad_channel = [c.topic for c in summary.channels.values() if c.message_encoding != "cdr"]
    compressions = {ci.compression for ci in summary.chunk_indexes}
    if bad_schema or bad_channel or compressions != {"zstd"}:
        sys.exit(f"FAIL encodings: schemas {bad_schema}, channels {bad_channel}, chunks {compressions}")
    print(f"profile ros2, {len(summary.schemas)} ros2msg schemas, {len(summary.channels)} cdr channels, "
          f"{len(summary.chunk_indexes)} zstd chunks")
    got = []
    for m in read_ros2_messages(bag):
        got.append({
            "topic": m.channel.topic,
            "type": m.schema.name,
            "log_time_ns": m.log_time_ns,
            "publish_time_ns": m.publish_time_ns,
            "msg": plain(m.ros_msg),
        })
    compare_lists(expected, got, "mcap_ros2 read_ros2_messages of cowork_bag's bag")


def header(t):
    return {"stamp": {"sec": t // 1_000_000_000, "nanosec": t % 1_000_000_000},
            "frame_id": "camera_depth_optical_frame"}


def write_theirs(bag, expect):
    width, height = 8, 6
    rows = []
    with open(bag, "wb") as f:
        # Small chunks, so a truncated copy still holds whole chunks to recover.
        writer = Writer(f, chunk_size=4096)
        image = writer.register_msgdef("sensor_msgs/msg/Image", IMAGE)
        info = writer.register_msgdef("sensor_msgs/msg/CameraInfo", CAMERA_INFO)
        joints = writer.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE)

        def put(topic, schema, t, msg):
            writer.write_message(topic, schema, msg, log_time=t, publish_time=t - 100)
            rows.append({"topic": topic, "type": schema.name, "log_time_ns": t,
                         "publish_time_ns": t - 100, "msg": plain(msg)})

        for k in range(10):
            t = 5_000_000_000 + k * 33_333_333
            mm = [500 + 3 * i + 7 * k for i in range(width * height)]
            put("/camera/depth/image_raw", image, t, {
                "header": header(t), "height": height, "width": width, "encoding": "16UC1",
                "is_bigendian": 0, "step": width * 2, "data": struct.pack(f"<{len(mm)}H", *mm)})
            metres = [0.5 + 0.001 * i + 0.25 * k for i in range(width * height)]
            put("/camera/depth/image_float", image, t + 1, {
                "header": header(t), "height": height, "width": width, "encoding": "32FC1",
                "is_bigendian": 0, "step": width * 4, "data": struct.pack(f"<{len(metres)}f", *metres)})
            put("/camera/depth/camera_info", info, t + 2, {
                "header": header(t), "height": height, "width": width, "distortion_model": "plumb_bob",
                "d": [0.1, -0.01, 0.0, 0.0, 0.001 * k], "k": [525.0, 0, 3.5, 0, 525.0, 2.5, 0, 0, 1],
                "r": [1.0, 0, 0, 0, 1, 0, 0, 0, 1], "p": [525.0, 0, 3.5, 0, 0, 525.0, 2.5, 0, 0, 0, 1, 0],
                "binning_x": 0, "binning_y": 0,
                "roi": {"x_offset": k, "y_offset": 1, "height": 2, "width": 3, "do_rectify": k % 2 == 0}})
            put("/joint_states", joints, t + 3, {
                "header": {"stamp": {"sec": 5, "nanosec": k}, "frame_id": ""},
                "name": [f"lwr_a{j}_joint" for j in range(1, 8)],
                "position": [0.1 * k - 0.3 * j for j in range(7)],
                "velocity": [1e-3 * j * k for j in range(7)], "effort": []})
        writer.finish()
    # mcap_ros2 fills integer-valued float fields from ints; JSON compares 525 == 525.0 anyway.
    with open(expect, "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
    print(f"mcap_ros2 Writer wrote {len(rows)} messages to {bag}")


def main():
    mode = sys.argv[1]
    if mode == "read-ours":
        read_ours(sys.argv[2], sys.argv[3])
    elif mode == "write-theirs":
        write_theirs(sys.argv[2], sys.argv[3])
    elif mode == "compare-prefix":
        expected, got = load(sys.argv[2]), load(sys.argv[3])
        if not 0 < len(got) < len(expected):
            sys.exit(f"FAIL truncated bag: recovered {len(got)} of {len(expected)} messages")
        compare_lists(expected[: len(got)], got, "cowork_bag recovering a truncated copy of mcap_ros2's bag")
    elif mode == "compare":
        compare_lists(load(sys.argv[2]), load(sys.argv[3]), "cowork_bag reading mcap_ros2's bag")
    else:
        sys.exit(f"unknown mode {mode!r}")


if __name__ == "__main__":
    main()
