"""Scenario bags of `cowork bag synth` against the PyPI `mcap` + `mcap-ros2-support` packages.

  check_synth.py BAG SCENARIO DURATION_S

Decodes every message of BAG with mcap_ros2.reader.read_ros2_messages (an independent CDR
decoder driven by the bag's ros2msg schemas), checks the count per topic against the MCAP
summary statistics and against the stream rates of the scenario (clock/joint_states 100 Hz,
tf 50 Hz, depth + camera info 30 Hz, Xsens 120 Hz, depth tracker 30 Hz, wrench 100 Hz), and
checks field values: image size / encoding / step / data length, camera intrinsics, the 11
Xsens segments, joint names, wrench frame, speech vocabulary, gesture label JSON.
Kinesthetic demonstrations (kinesthetic-pour | -coffee | -spoon | -tea) are also checked with an
independent forward kinematics (kinpy on config/robot/lwr4plus.urdf) of the bag's /joint_states:
at `gripper close` the tool is right above the scenario's object (config/scenes/kitchen.yaml),
while holding it the tool passes over the cup, and the pour / coffee / tea demonstrations tilt the
tool past 95 deg there (the spoon's stir stays at or below 95 deg); joint speeds stay under the LWR's limits.
Exits non-zero on any mismatch; prints the figures.
"""

import json
import math
import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.reader import read_ros2_messages

XSENS = ["pelvis", "sternum", "head", "right_shoulder", "right_elbow", "right_wrist", "right_hand",
         "left_shoulder", "left_elbow", "left_wrist", "left_hand"]
SPEECH = {"teach", "done", "stop", "repeat", "gripper open", "gripper close"}
GESTURES = {"come", "stop", "handover_right"}

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("  FAIL:", what)


def ticks(rate, duration):
    """Messages of a stream with ticks at k / rate for k = 0.. while k / rate <= duration."""
    return math.floor(duration * rate + 1e-6) + 1


# The object each kinesthetic demonstration grasps, and whether it is tilted over the cup.
DEMONSTRATIONS = {"kinesthetic-pour": ("bottle", True), "kinesthetic-coffee": ("coffee", True),
                  "kinesthetic-tea": ("tea", True), "kinesthetic-spoon": ("spoon", False)}
# LWR IV+ joint speed limits (deg/s, SPEC).
SPEED_LIMITS_DEG = [100, 110, 100, 130, 130, 180, 180]


def check_demonstration(path, scenario):
    """The teacher's motion, by kinpy's forward kinematics of /joint_states."""
    if scenario not in DEMONSTRATIONS:
        check(False, f"unknown kinesthetic scenario {scenario}")
        return
    import kinpy as kp
    import numpy as np
    import yaml

    with open("config/robot/lwr4plus.urdf", "rb") as f:
        chain = kp.build_serial_chain_from_urdf(f.read().decode("utf-8"), "lwr_ee_link")
    with open("config/scenes/kitchen.yaml") as f:
        scene = {o["name"]: o for o in yaml.safe_load(f)["objects"]}
    obj_name, tilted = DEMONSTRATIONS[scenario]
    obj = scene[obj_name]
    shape = obj["shape"]
    top = obj["pose"]["position"][2] + (shape["height"] if shape["type"] == "cylinder" else shape["size"][2]) / 2
    cup = np.array(scene["cup"]["pose"]["position"])
    joints, words = [], []
    for m in read_ros2_messages(path, topics=["/joint_states", "/speech_command"]):
        t = m.log_time_ns * 1e-9
        if m.channel.topic == "/joint_states":
            joints.append((t, np.array(m.ros_msg.position)))
        else:
            words.append((t, m.ros_msg.data))
    times = np.array([t for t, _ in joints])
    q = np.array([p for _, p in joints])

    def tool_at(t):
        k = int(np.argmin(np.abs(times - t)))
        return chain.forward_kinematics(q[k])

    close = [t for t, w in words if w == "gripper close"]
    opened = [t for t, w in words if w == "gripper open"]
    if not (close and opened and close[0] < opened[0]):
        check(False, f"{scenario}: no gripper close before gripper open: {words}")
        return
    p = tool_at(close[0]).pos
    horizontal = float(np.hypot(p[0] - obj["pose"]["position"][0], p[1] - obj["pose"]["position"][1]))
    above = float(p[2] - top)
    check(horizontal <= 0.03 and 0.0 <= above <= 0.06,
          f"{scenario}: at gripper close the tool is {horizontal:.3f} m beside and {above:.3f} m above the {obj_name}'s top")
    # While holding: over the cup, and tilted there (pour / shake) or not (stir).
    held = (times >= close[0]) & (times <= opened[0])
    over, tilt = np.inf, 0.0
    for k in np.flatnonzero(held)[::5]:
        f = chain.forward_kinematics(q[k])
        h = float(np.hypot(f.pos[0] - cup[0], f.pos[1] - cup[1]))
        over = min(over, h)
        if h < 0.15:
            z = kp.Transform(f.rot, f.pos).matrix()[:3, 2]
            tilt = max(tilt, float(np.degrees(np.arccos(np.clip(-z[2], -1.0, 1.0)))))
    check(over <= 0.03, f"{scenario}: the tool never came over the cup while holding ({over:.3f} m)")
    check(tilt > 95.0 if tilted else tilt <= 95.0, f"{scenario}: tool tilt over the cup {tilt:.1f} deg")
    speed = np.max(np.abs(np.diff(q, axis=0)) / np.maximum(np.diff(times), 1e-9)[:, None], axis=0)
    limits = np.radians(SPEED_LIMITS_DEG)
    check(bool(np.all(speed <= limits)), f"{scenario}: joint speeds {np.round(speed, 2)} rad/s over the limits")
    print(f"    demonstration: grasp {horizontal * 1e3:.0f} mm beside / {above * 1e3:.0f} mm above the {obj_name}, "
          f"over the cup within {over * 1e3:.0f} mm, tilt there {tilt:.1f} deg, fastest joint {np.max(speed / limits) * 100:.0f} % of its limit")


def main():
    path, scenario, duration = sys.argv[1], sys.argv[2], float(sys.argv[3])
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    stats = summary.statistics
    by_channel = {summary.channels[c].topic: n for c, n in stats.channel_message_counts.items()}

    counts = Counter()
    image_sizes = set()
    skeleton_sources = Counter()
    labels = []
    wrench_frames = set()
    speech = []
    last_time = {}
    for m in read_ros2_messages(path):
        topic = m.channel.topic
        counts[topic] += 1
        msg = m.ros_msg
        prev = last_time.get(topic, -1)
        check(m.log_time_ns >= prev, f"{topic}: log time goes back at {m.log_time_ns}")
        last_time[topic] = m.log_time_ns
        if topic == "/camera/depth/image_raw":
            image_sizes.add((msg.width, msg.height, msg.encoding, msg.step))
            if len(msg.data) != msg.step * msg.height:
                check(False, f"image data {len(msg.data)} B != step x height")
        elif topic == "/camera/depth/camera_info":
            check(list(msg.k) == [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0],
                  f"camera_info k {list(msg.k)}")
        elif topic == "/human/skeleton":
            skeleton_sources[msg.source] += 1
            check(list(msg.segment_names) == XSENS and len(msg.poses) == 11,
                  f"skeleton segments {list(msg.segment_names)}")
            check(msg.header.frame_id == "lwr_base_link", f"skeleton frame {msg.header.frame_id}")
        elif topic == "/joint_states":
            check(list(msg.name) == [f"lwr_joint_{i}" for i in range(1, 8)] and len(msg.position) == 7,
                  f"joint names {list(msg.name)}")
        elif topic == "/external_wrench":
            wrench_frames.add(msg.header.frame_id)
        elif topic == "/speech_command":
            speech.append(msg.data)
        elif topic == "/human/gesture_label":
            labels.append(json.loads(msg.data))

    total = sum(counts.values())
    print(f"  {path}: {total} messages decoded by mcap_ros2 ({stats.message_count} in the summary)")
    for topic in sorted(counts):
        print(f"    {topic:<30} {counts[topic]:>7}")
    check(total == stats.message_count, "decoded count != summary message count")
    for topic, n in by_channel.items():
        check(counts[topic] == n, f"{topic}: decoded {counts[topic]} != summary {n}")

    expect = {"/clock": ticks(100, duration), "/joint_states": ticks(100, duration),
              "/tf": ticks(50, duration), "/tf_static": 1}
    if "/camera/depth/image_raw" in counts:
        expect["/camera/depth/image_raw"] = ticks(30, duration)
        expect["/camera/depth/camera_info"] = ticks(30, duration)
        check(image_sizes == {(640, 480, "16UC1", 1280)}, f"image sizes {image_sizes}")
    if scenario.startswith("kinesthetic-"):
        check(counts["/external_wrench"] >= 90 * duration, f"wrench count {counts['/external_wrench']}")
        check(wrench_frames == {"lwr_base_link"}, f"wrench frames {wrench_frames}")
        check(speech == ["teach", "gripper close", "gripper open", "done"], f"speech {speech}")
        check_demonstration(path, scenario)
    elif scenario == "stacking-human":
        n = counts["/human/skeleton"]
        check(set(skeleton_sources) == {"xsens"}, f"skeleton sources {dict(skeleton_sources)}")
        # Xsens at 120 Hz while the person is there (enters at 1 s).
        check(100 * (duration - 1.0) * 0.5 <= n <= 120 * duration + 1, f"skeleton count {n}")
    elif scenario == "gestures":
        check(set(skeleton_sources) == {"depth_tracker"}, f"skeleton sources {dict(skeleton_sources)}")
        check(len(labels) >= 3, f"{len(labels)} labels")
        for lab in labels:
            check(lab["label"] in GESTURES and 0 <= lab["start"] < lab["end"] <= duration + 1e-6,
                  f"label {lab}")
        print(f"    labels: {Counter(l['label'] for l in labels)}")
    elif scenario == "static-scene":
        check("/human/skeleton" not in counts, "a skeleton in the static scene")
    for topic, n in expect.items():
        check(counts[topic] == n, f"{topic}: {counts[topic]} messages, expected {n} at its rate")
    check(all(w in SPEECH for w in speech), f"speech outside the vocabulary: {speech}")
    if failures:
        sys.exit(f"{len(failures)} mismatches in {path}")


if __name__ == "__main__":
    main()
