"""Judges a pour execution from what the simulator reported (/lwr/world in RUN.mcap), never
from commands: the bottle was grasped, carried over the cup and tilted there (mouth towards the
cup, tilt > 90 deg), released upright on the table. Prints one JSON line with the times of
take(water) and pour(water) from the action events on /robot_stream.

    python3 judge_pour.py RUN.mcap   (needs mcap_ros2, e.g. .venv-crosscheck/bin/python)"""

import json
import math
import sys

from mcap_ros2.reader import read_ros2_messages


def main():
    path = sys.argv[1]
    worlds, events = [], []
    for m in read_ros2_messages(path, topics=["/lwr/world", "/robot_stream"]):
        if m.channel.topic == "/lwr/world":
            w = m.ros_msg
            t = w.header.stamp.sec + 1e-9 * w.header.stamp.nanosec
            objs = {o.name: o for o in w.objects}
            worlds.append((t, w.held_object, objs))
        else:
            r = m.ros_msg
            t = r.header.stamp.sec + 1e-9 * r.header.stamp.nanosec
            for e in r.events:
                events.append((t, e.label, e.done, e.failed, e.reason))
    if not worlds:
        print(json.dumps({"success": False, "reason": "no /lwr/world in the bag"}))
        return 1
    cup = worlds[0][2]["cup"].pose.position
    held = [w for w in worlds if w[1] == "bottle"]
    poured = [
        w for w in held
        if math.hypot(w[2]["bottle"].pose.position.x - cup.x, w[2]["bottle"].pose.position.y - cup.y) < 0.15
        and w[2]["bottle"].tilt > math.radians(90)
    ]
    last = worlds[-1][2]["bottle"]
    start = worlds[0][2]["bottle"].pose.position
    checks = {
        "grasped": bool(held),
        "tilted_over_cup": bool(poured),
        "released": worlds[-1][1] == "",
        "upright": last.tilt < math.radians(10),
        "on_table": abs(last.pose.position.z - 0.11) < 0.02,
    }

    def span(first, last_label):
        t0 = next((t for t, l, d, f, _ in events if l == first and not d and not f), None)
        t1 = next((t for t, l, d, f, _ in events if l == last_label and d), None)
        return None if t0 is None or t1 is None else round(t1 - t0, 2)

    out = {
        "success": all(checks.values()),
        "checks": checks,
        "bottle_start": [round(start.x, 3), round(start.y, 3)],
        "bottle_end": [round(last.pose.position.x, 3), round(last.pose.position.y, 3), round(last.pose.position.z, 3)],
        "max_tilt_over_cup_deg": round(math.degrees(max((w[2]["bottle"].tilt for w in poured), default=0.0)), 1),
        "tilted_over_cup_s": round(len(poured) / 100.0, 2),
        "take_s": span("foa1(water)", "close3(water)"),
        "pour_s": span("foa4(cup)", "open7(water)"),
        "failed": [(l, r) for _, l, _, f, r in events if f],
    }
    print(json.dumps(out))
    return 0 if out["success"] else 1


if __name__ == "__main__":
    sys.exit(main())
