"""Judges a pour execution from what the simulator reported (/lwr/world in RUN.mcap), never
from commands: the bottle was grasped, carried over the cup and tilted there (mouth towards the
cup, tilt > 90 deg), released upright on the table. Prints one JSON line with the times of
take(water) and pour(water) from the action events on /robot_stream, and the subtask times of
thesis Table 5.4 from the world alone (a recorder can miss the first events while DDS discovery
runs): take = first tool motion -> bottle held, pour = held -> released, add = the two.

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
            tool = (w.tool_pose.position.x, w.tool_pose.position.y, w.tool_pose.position.z)
            worlds.append((t, w.held_object, objs, tool))
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

    # Subtask times from the world: the tool's first 5 mm of motion, the grasp, the release.
    t_move = next((w[0] for w in worlds if math.dist(w[3], worlds[0][3]) > 0.005), None)
    t_held = next((w[0] for w in worlds if w[1] == "bottle"), None)
    t_free = next((w[0] for w in worlds if t_held is not None and w[0] > t_held and w[1] == ""), None)
    world_times = {
        "take_s": None if t_move is None or t_held is None else round(t_held - t_move, 2),
        "pour_s": None if t_held is None or t_free is None else round(t_free - t_held, 2),
        "add_s": None if t_move is None or t_free is None else round(t_free - t_move, 2),
    }
    out = {
        "success": all(checks.values()),
        "checks": checks,
        "bottle_start": [round(start.x, 3), round(start.y, 3)],
        "bottle_end": [round(last.pose.position.x, 3), round(last.pose.position.y, 3), round(last.pose.position.z, 3)],
        "max_tilt_over_cup_deg": round(math.degrees(max((w[2]["bottle"].tilt for w in poured), default=0.0)), 1),
        "tilted_over_cup_s": round(len(poured) / 100.0, 2),
        "take_s": span("foa1(water)", "close3(water)"),
        "pour_s": span("foa4(cup)", "open7(water)"),
        "world_times": world_times,
        "failed": [(l, r) for _, l, _, f, r in events if f],
    }
    print(json.dumps(out))
    return 0 if out["success"] else 1


if __name__ == "__main__":
    sys.exit(main())
