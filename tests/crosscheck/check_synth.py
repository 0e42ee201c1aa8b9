"""Scenario bags of `cowork bag synth` against the PyPI `mcap` + `mcap-ros2-support` packages.

  check_synth.py BAG SCENARIO DURATION_S

Decodes every message of BAG with mcap_ros2.reader.read_ros2_messages (an independent CDR
decoder driven by the bag's ros2msg schemas), checks the count per topic against the MCAP
summary statistics and against the stream rates of the scenario (clock/joint_states 100 Hz,
tf 50 Hz, depth + camera info 30 Hz, Xsens 120 Hz, depth tracker 30 Hz, wrench 100 Hz), and
checks field values: image size / encoding / step / data length, camera intrinsics, the 11
Xsens segments, joint names, wrench frame, speech vocabulary, gesture label JSON.
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
    if scenario == "kinesthetic-pour":
        check(counts["/external_wrench"] >= 90 * duration, f"wrench count {counts['/external_wrench']}")
        check(wrench_frames == {"lwr_base_link"}, f"wrench frames {wrench_frames}")
        check(speech == ["teach", "gripper close", "gripper open", "done"], f"speech {speech}")
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
