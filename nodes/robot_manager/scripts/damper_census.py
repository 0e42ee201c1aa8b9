"""What does ds_controller's link damper react to? For a run recorded with
`RECORD_EXTRA="/fded/distances /tf" execute_pour.sh ...`, every `/motion/status` that says
"approach limited: LINK" is matched with the newest `/fded/distances` at or before it, and that
link's closest obstacle point is classified from what the simulator reported (`/lwr/world`
object poses, `/tf` link frames), never from what fDED believed:

- `object NAME (held|target|scene)`: inside the scene object's shape grown by 4 cm;
- `shadow of NAME`: behind that object seen from the scene's camera (fDED's gray area, eq.
  5.17: the segment from the camera to the point passes through the grown shape);
- `table`: within 4 cm of the table top (z = 0);
- `robot`: within 9 cm of the robot's link chain (self-pixels left by the robot removal);
- `unexplained`: anything else (printed with coordinates).

Per action (from `/robot_stream` events), prints counts per class and the smallest reported
distance of each class.

    python3 damper_census.py RUN.mcap [config/scenes/kitchen.yaml]
    (needs mcap_ros2 and PyYAML, e.g. .venv-crosscheck/bin/python)"""

import bisect
import collections
import math
import re
import sys

import yaml
from mcap_ros2.reader import read_ros2_messages

OBJECT_MARGIN = 0.04
TABLE_BAND = 0.04
ROBOT_RADIUS = 0.09


def stamp(h):
    return h.stamp.sec + 1e-9 * h.stamp.nanosec


def quat_rotate(q, v):
    # q = (x, y, z, w); v = (x, y, z)
    x, y, z, w = q
    vx, vy, vz = v
    # t = 2 q_vec x v
    tx, ty, tz = 2 * (y * vz - z * vy), 2 * (z * vx - x * vz), 2 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx))


def base_position(edges, frame, base="lwr_base_link"):
    """Position of `frame`'s origin in the base frame, composing /tf parent by parent."""
    p = (0.0, 0.0, 0.0)
    for _ in range(len(edges) + 1):
        if frame == base:
            return p
        t = edges.get(frame)
        if t is None:
            return None
        r, tr = t.transform.rotation, t.transform.translation
        q = (r.x, r.y, r.z, r.w)
        v = quat_rotate(q, p)
        p = (v[0] + tr.x, v[1] + tr.y, v[2] + tr.z)
        frame = t.header.frame_id
    return None


def inside(shape, pose, p, margin):
    pos, q = pose
    d = (p[0] - pos[0], p[1] - pos[1], p[2] - pos[2])
    qi = (-q[0], -q[1], -q[2], q[3])
    lx, ly, lz = quat_rotate(qi, d)
    if shape["type"] == "cylinder":
        return math.hypot(lx, ly) <= shape["radius"] + margin and abs(lz) <= shape["height"] / 2 + margin
    if shape["type"] == "box":
        s = shape["size"]
        return abs(lx) <= s[0] / 2 + margin and abs(ly) <= s[1] / 2 + margin and abs(lz) <= s[2] / 2 + margin
    if shape["type"] == "sphere":
        return math.sqrt(lx * lx + ly * ly + lz * lz) <= shape["radius"] + margin
    return False


def seg_dist(p, a, b):
    ab = [b[i] - a[i] for i in range(3)]
    ap = [p[i] - a[i] for i in range(3)]
    L = sum(x * x for x in ab)
    t = 0.0 if L < 1e-12 else max(0.0, min(1.0, sum(ab[i] * ap[i] for i in range(3)) / L))
    c = [a[i] + t * ab[i] for i in range(3)]
    return math.dist(p, c)


def main():
    path = sys.argv[1]
    scene_path = sys.argv[2] if len(sys.argv) > 2 else "config/scenes/kitchen.yaml"
    with open(scene_path) as f:
        scene = yaml.safe_load(f)
    shapes = {o["name"]: o["shape"] for o in scene["objects"]}
    camera = tuple(scene["camera"]["pose"]["position"]) if "camera" in scene else None
    worlds, tfs, dists, statuses, events = [], [], [], [], []
    for m in read_ros2_messages(path, topics=["/lwr/world", "/tf", "/fded/distances", "/motion/status", "/robot_stream"]):
        msg = m.ros_msg
        topic = m.channel.topic
        if topic == "/lwr/world":
            objs = {
                o.name: ((o.pose.position.x, o.pose.position.y, o.pose.position.z),
                         (o.pose.orientation.x, o.pose.orientation.y, o.pose.orientation.z, o.pose.orientation.w))
                for o in msg.objects
            }
            worlds.append((stamp(msg.header), msg.held_object, objs))
        elif topic == "/tf":
            # /tf is the link tree (each link in its parent's frame): compose up to the base.
            edges = {t.child_frame_id: t for t in msg.transforms}
            links = {}
            for name in edges:
                if name.startswith("lwr_"):
                    p = base_position(edges, name)
                    if p is not None:
                        links[name] = p
            if links:
                tfs.append((stamp(msg.transforms[0].header), links))
        elif topic == "/fded/distances":
            dists.append((stamp(msg.header), msg))
        elif topic == "/motion/status":
            statuses.append((stamp(msg.header), msg))
        elif topic == "/robot_stream":
            for e in msg.events:
                events.append((stamp(msg.header), e.label, e.done, e.failed))
    if not (worlds and tfs and dists):
        print("the bag needs /lwr/world, /tf and /fded/distances (RECORD_EXTRA)")
        return 1
    wt = [w[0] for w in worlds]
    tt = [t[0] for t in tfs]
    dt = [d[0] for d in dists]
    starts = sorted((t, l) for t, l, d, f in events if not d and not f)

    def action_at(t):
        i = bisect.bisect_right([s[0] for s in starts], t) - 1
        return starts[i][1] if i >= 0 else "(none)"

    def newest(ts, items, t):
        i = bisect.bisect_right(ts, t) - 1
        return items[max(i, 0)]

    census = collections.defaultdict(collections.Counter)
    closest = collections.defaultdict(lambda: math.inf)
    unexplained = []
    chain = ["lwr_link_1", "lwr_link_2", "lwr_link_3", "lwr_link_4", "lwr_link_5", "lwr_link_6", "lwr_link_7", "lwr_ee_link"]
    for t, st in statuses:
        mm = re.search(r"approach limited: (\S+)", st.reason)
        if not mm:
            continue
        link = mm.group(1)
        _, d = newest(dt, dists, t)
        entry = next((l for l in d.links if l.link_name == link), None)
        if entry is None or not entry.valid:
            continue
        p = (entry.obstacle_point.x, entry.obstacle_point.y, entry.obstacle_point.z)
        _, held, objs = newest(wt, worlds, stamp(d.header))
        _, links = newest(tt, tfs, stamp(d.header))
        act = action_at(t)
        target = re.search(r"\((\w+)\)", act)
        target = target.group(1) if target else ""
        cls = None
        for name, pose in objs.items():
            if name in shapes and inside(shapes[name], pose, p, OBJECT_MARGIN):
                role = "held" if name == held else ("target" if name == target else "scene")
                cls = f"object {name} ({role})"
                break
        if cls is None and camera is not None:
            for name, pose in objs.items():
                if name not in shapes:
                    continue
                length = math.dist(p, camera)
                steps = int(min(length, 2.0) / 0.01)
                if any(inside(shapes[name], pose, [p[k] + (camera[k] - p[k]) * (0.01 * i / length) for k in range(3)], OBJECT_MARGIN)
                       for i in range(1, steps + 1)):
                    cls = f"shadow of {name}"
                    break
        if cls is None and abs(p[2]) <= TABLE_BAND:
            cls = "table"
        if cls is None:
            pts = [(0.0, 0.0, 0.0)] + [links[c] for c in chain if c in links]
            if min(seg_dist(p, pts[i], pts[i + 1]) for i in range(len(pts) - 1)) <= ROBOT_RADIUS:
                cls = "robot"
        if cls is None:
            cls = "unexplained"
            if len(unexplained) < 10:
                unexplained.append((round(t, 2), link, [round(x, 3) for x in p], round(entry.distance, 3)))
        census[act][(link, cls)] += 1
        closest[(act, cls)] = min(closest[(act, cls)], entry.distance)
    print(f"{path}: {sum(sum(c.values()) for c in census.values())} 'approach limited' statuses")
    for act, c in census.items():
        print(f"  {act}:")
        for (link, cls), n in c.most_common():
            print(f"    {n:5d}  {link:12s} {cls:28s} closest reported {closest[(act, cls)]:.3f} m")
    for u in unexplained:
        print("  unexplained:", u)
    return 0


if __name__ == "__main__":
    sys.exit(main())
