"""The stranger test: an independent DDS peer (Cyclone DDS) attacks the running graph.

It starts lwr_sim, fded_distance, human_observer and ds_controller as processes (release
binaries, bundled parameters, the stacking scene with a 320 x 240 camera, lwr_sim's simulated
clock at real-time rate, domain DOMAIN). This peer

* plays the person: one standing frame of `bags/stacking-human.mcap` (close to the table,
  inside human_observer's interaction distance) re-stamped onto `/clock` at 30 Hz on
  `/human/skeleton`, so lwr_sim draws them in the depth image (fded_distance sees them) and
  human_observer reports interaction (alpha_h = 0.1 m/s);
* plays the task: a constant-speed shuttle of the tool (+-0.2 m along y) on `/motion/command`;
* attacks, one class after the other, each for a few seconds, with what a foreign node on the
  same domain could publish, and judges the robot's motion from the simulated world
  (`/lwr/world` tool pose, `/joint_states`), never from what was commanded.

Per class it prints the messages sent, the nodes alive after it (process up and still
publishing its output topic), the largest tool speed and joint speed during the attack, and

* `changed`: the robot's motion differed from the undisturbed shuttle (held, slowed, moved);
* `unsafe`: the tool moved faster than the person's presence allows (interaction speed + 30 %)
  for 0.2 s or more, or a joint faster than the shuttle ever needs (baseline + margin) — "got
  through".

Exit status: non-zero when a node died, or when an attack that the graph is meant to resist got
through. Direct joint commands are expected to get through (lwr_sim obeys whoever publishes
`/lwr/joint_velocity_command`: without DDS security any peer on the domain can drive the arm);
they are reported, not failed. After the attacks, two chaos cases (fded_distance stopped and
continued, then killed and restarted, 1.5 s down each).

Mode `secure`: DDS Security (see `secure` below): a peer without credentials floods a topic
between two secured cowork processes; prints "N sent, 0 through".

Mode `chaos`: no attacks; SIGSTOP (then SIGCONT) and SIGKILL (then a restart) of fded_distance,
human_observer and ds_controller in turn during the shuttle, each down 2 s: time until the robot
is held, tool path and joint motion after the fault, time to resume, shuttle legs completed.

    python stranger.py DOMAIN [check|chaos|secure]      (CYCLONEDDS_URI as check_stranger.sh sets it;
                                                 BIN=target/release, STRANGER_ONLY=substring,
                                                 STRANGER_DUMP=samples.json)
"""

import json
import math
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from dds_peer import Float64MultiArray, Header, JointState, MultiArrayLayout, Time

ATTACK_S = 3.0  # wall seconds per attack class
RECOVER_S = 1.5  # wall seconds after each class before the next
BASELINE_S = 8.0  # two shuttle legs: the joint speeds of the whole path, both ways
FAR = 0.3
INTERACTION = 0.1
SHUTTLE_HALF_M = 0.2
WINDOW_S = 0.1  # tool / joint speed windows (s of simulated time)
UNSAFE_TOOL = INTERACTION * 1.3
SUSTAINED_S = 0.2  # s over UNSAFE_TOOL that count as getting through


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
class Skeleton(IdlStruct, typename="cowork_msgs::msg::dds_::Skeleton_"):
    header: Header
    source: str
    person_id: uint32
    segment_names: sequence[str]
    poses: sequence[Pose]
    velocities: sequence[Twist]


@dataclass
class HumanState(IdlStruct, typename="cowork_msgs::msg::dds_::HumanState_"):
    header: Header
    mode: uint8
    present: bool
    distance: float64
    hand_position: Point
    hand_velocity: Vector3
    speed_scale: float64
    stopped: bool


@dataclass
class LinkDistance(IdlStruct, typename="cowork_msgs::msg::dds_::LinkDistance_"):
    link_name: str
    distance: float64
    robot_point: Point
    obstacle_point: Point
    normal: Vector3
    obstacle_velocity: Vector3
    valid: bool


@dataclass
class LinkDistances(IdlStruct, typename="cowork_msgs::msg::dds_::LinkDistances_"):
    header: Header
    links: sequence[LinkDistance]
    min_index: int32
    processing_time: float64
    backend: str


@dataclass
class MotionCommand(IdlStruct, typename="cowork_msgs::msg::dds_::MotionCommand_"):
    header: Header
    id: uint32
    kind: uint8
    label: str
    parameters_json: str
    parameters: sequence[float64]
    goal: Pose
    nominal_speed: float64
    hold_orientation: bool
    end_effector_avoidance_off: bool


@dataclass
class MotionStatus(IdlStruct, typename="cowork_msgs::msg::dds_::MotionStatus_"):
    header: Header
    command_id: uint32
    state: uint8
    reason: str
    goal_error: float64


@dataclass
class WorldObject(IdlStruct, typename="cowork_msgs::msg::dds_::WorldObject_"):
    name: str
    pose: Pose
    tool_distance: float64
    tilt: float64
    held: bool


@dataclass
class WorldState(IdlStruct, typename="cowork_msgs::msg::dds_::WorldState_"):
    header: Header
    gripper_state: uint8
    held_object: str
    tool_pose: Pose
    objects: sequence[WorldObject]


KIND_DMP, KIND_CONSTANT_SPEED = 2, 1
STATE_RUNNING, STATE_CONVERGED, STATE_ABORTED, STATE_HELD = 0, 1, 2, 3
LINKS = [f"lwr_link_{i}" for i in range(1, 8)]


def secs(t):
    return t.sec + t.nanosec * 1e-9


def stamp(s):
    s = max(0.0, s)
    return Time(int(s), int((s - int(s)) * 1e9) % 1_000_000_000)


def header(s, frame="lwr_base_link"):
    return Header(stamp(s), frame)


def person_frame(bag, at=7.5):
    """The `/human/skeleton` frame of `bag` stamped nearest `at` s (standing near the table)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    best = None
    with open(bag, "rb") as f:
        r = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, _, m in r.iter_decoded_messages(topics=["/human/skeleton"]):
            if best is None or abs(secs(m.header.stamp) - at) < abs(secs(best.header.stamp) - at):
                best = m
    if best is None:
        raise SystemExit(f"FAIL: {bag} has no /human/skeleton")
    p = lambda v: Point(v.x, v.y, v.z)  # noqa: E731
    poses = [Pose(p(x.position), Quaternion(x.orientation.x, x.orientation.y, x.orientation.z, x.orientation.w)) for x in best.poses]
    zero = Twist(Vector3(0.0, 0.0, 0.0), Vector3(0.0, 0.0, 0.0))
    return best.source, best.person_id, list(best.segment_names), poses, [zero] * len(poses)


class Graph:
    """The four node processes (release binaries, bundled parameters), logs in `logs`."""

    NODES = ("human_observer", "ds_controller", "fded_distance", "lwr_sim")

    def __init__(self, domain, root, bin_dir, scene, logs, duration=400):
        self.root, self.bin_dir, self.logs = root, bin_dir, logs
        self.env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
        d = str(duration)
        self.args = {
            "human_observer": ["--params", "config/human_observer.yaml", "--use-sim-time", "--duration", d],
            "ds_controller": ["--params", "config/ds_controller.yaml", "--use-sim-time", "--duration", d],
            "fded_distance": ["--params", "config/fded_distance.yaml", "--use-sim-time", "--duration", d],
            "lwr_sim": ["--scene", scene, "--params", "config/lwr_sim.yaml", "--rate", "1", "--duration", d],
        }
        self.procs = {}
        for n in self.NODES:
            self.start(n)

    def start(self, name):
        log = open(os.path.join(self.logs, f"{name}.log"), "ab")
        self.procs[name] = subprocess.Popen([os.path.join(self.bin_dir, name), *self.args[name]], cwd=self.root,
                                            stdout=log, stderr=subprocess.STDOUT, env=self.env)

    def pid(self, name):
        return self.procs[name].pid

    def signal(self, name, sig):
        os.kill(self.procs[name].pid, sig)
        if sig == signal.SIGKILL:
            self.procs[name].wait()

    def pids(self):
        return {n: p.pid for n, p in self.procs.items()}

    def stop(self):
        for p in self.procs.values():
            if p.poll() is None:
                p.send_signal(signal.SIGCONT)
                p.send_signal(signal.SIGINT)
        end = time.monotonic() + 5
        for p in self.procs.values():
            try:
                p.wait(timeout=max(0.1, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()

    def tail(self, n=int(os.environ.get("STRANGER_TAIL", "15"))):
        out = []
        for name in self.NODES:
            with open(os.path.join(self.logs, f"{name}.log"), errors="replace") as f:
                lines = f.read().splitlines()[-n:]
            out.append(f"--- {name} log (last {n} lines)\n" + "\n".join(lines))
        return "\n".join(out)


def alive(pid):
    """The process is running (not gone, not a zombie)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
        return state not in ("Z", "X")
    except OSError:
        return False


def attack_writers(dp, dp_wrong, qos):
    """The writers `attacks` uses, by attribute name; the wrong-type ones in `dp_wrong` (one
    participant may not hold two types on one topic name)."""
    t = lambda name, ty: Topic(dp, name, ty)  # noqa: E731
    return {
        "w_motion": DataWriter(dp, t("rt/motion/command", MotionCommand), qos=qos),
        "w_joint_cmd": DataWriter(dp, t("rt/lwr/joint_velocity_command", Float64MultiArray), qos=qos),
        "w_dist": DataWriter(dp, t("rt/fded/distances", LinkDistances), qos=qos),
        "w_human": DataWriter(dp, t("rt/human/state", HumanState), qos=qos),
        "w_speech": DataWriter(dp, t("rt/speech_command", String), qos=qos),
        "w_clock": DataWriter(dp, t("rt/clock", Clock), qos=qos),
        "w_wrong": {
            name: DataWriter(dp_wrong, Topic(dp_wrong, name, String), qos=qos)
            for name in ("rt/joint_states", "rt/fded/distances", "rt/human/state", "rt/motion/command",
                         "rt/human/skeleton", "rt/lwr/joint_velocity_command", "rt/clock",
                         "rt/camera/depth/image_raw")
        },
    }


class Attacker:
    """A blind stranger on one domain: the attack writers, and the graph's /clock for the stamps
    while it can read it (it cannot from a secured graph: stamps are then 0)."""

    def __init__(self, domain):
        qos = Qos(
            Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=5)),
            Policy.History.KeepLast(100),
            Policy.DataRepresentation(use_cdrv0_representation=True),
            Policy.IgnoreLocal.Process,
        )
        self.dp = DomainParticipant(domain)
        self.dp_wrong = DomainParticipant(domain)
        self.__dict__.update(attack_writers(self.dp, self.dp_wrong, qos))
        self.r_clock = DataReader(self.dp, Topic(self.dp, "rt/clock", Clock), qos=Qos(
            Policy.Reliability.BestEffort, Policy.History.KeepLast(100),
            Policy.DataRepresentation(use_cdrv0_representation=True), Policy.IgnoreLocal.Process))
        self.now = None  # newest /clock (s) heard from the graph
        self.clocks = 0

    def poll(self):
        for s in self.r_clock.take(N=1000):
            if isinstance(s, Clock):  # not a writer's dispose / unregister
                self.now = secs(s.clock)
                self.clocks += 1


class Peer:
    def __init__(self, domain, graph):
        self.graph = graph
        qos = Qos(
            Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=5)),
            Policy.History.KeepLast(2000),
            Policy.DataRepresentation(use_cdrv0_representation=True),
            # The peer's readers must not see its own attacks (a forged /clock, human state...).
            Policy.IgnoreLocal.Process,
        )
        best_effort = Qos(
            Policy.Reliability.BestEffort,
            Policy.History.KeepLast(2000),
            Policy.DataRepresentation(use_cdrv0_representation=True),
            Policy.IgnoreLocal.Process,
        )
        self.dp = DomainParticipant(domain)
        # The wrong-type writers live in a participant of their own (one participant may not
        # hold two types on one topic name).
        self.dp_wrong = DomainParticipant(domain)
        dp = self.dp
        t = lambda name, ty: Topic(dp, name, ty)  # noqa: E731
        self.r_clock = DataReader(dp, t("rt/clock", Clock), qos=best_effort)
        self.r_world = DataReader(dp, t("rt/lwr/world", WorldState), qos=best_effort)
        self.r_joints = DataReader(dp, t("rt/joint_states", JointState), qos=best_effort)
        self.r_status = DataReader(dp, t("rt/motion/status", MotionStatus), qos=qos)
        self.r_human = DataReader(dp, t("rt/human/state", HumanState), qos=best_effort)
        self.r_dist = DataReader(dp, t("rt/fded/distances", LinkDistances), qos=best_effort)
        self.w_skeleton = DataWriter(dp, t("rt/human/skeleton", Skeleton), qos=qos)
        self.__dict__.update(attack_writers(dp, self.dp_wrong, qos))
        self.now = None  # newest /clock (s)
        self.tool = []  # (t, x, y, z)
        self.joints = []  # (t, [q])
        self.statuses = []  # (t, command_id, state, reason)
        self.human = []  # (t, mode, present, speed_scale, stopped)
        self.heard = {}  # topic -> wall time last heard
        self.person = person_frame(os.path.join(os.path.dirname(__file__), "../../bags/stacking-human.mcap"))
        self.next_person = 0.0
        self.shuttle_id = 0
        self.goals = None
        self.sent_at = 0.0
        self.acked = 0.0
        self.converged = []  # stamps of the shuttle legs' CONVERGED reports

    # ---- the world as the peer sees it
    def poll(self):
        wall = time.monotonic()
        for s in self.r_clock.take(N=1000):
            self.now = secs(s.clock)
            self.heard["clock"] = wall
        for s in self.r_world.take(N=1000):
            p = s.tool_pose.position
            self.tool.append((secs(s.header.stamp), p.x, p.y, p.z))
            self.heard["world"] = wall
        for s in self.r_joints.take(N=5000):
            if len(s.position) == 7:
                self.joints.append((secs(s.header.stamp), list(s.position)))
            self.heard["lwr_sim"] = wall
        for s in self.r_status.take(N=1000):
            self.statuses.append((secs(s.header.stamp), s.command_id, s.state, s.reason))
            self.heard["ds_controller"] = wall
            if s.command_id == self.shuttle_id:
                self.acked = wall
            if s.command_id == self.shuttle_id and s.state == STATE_CONVERGED:
                self.converged.append(secs(s.header.stamp))
                self.send_shuttle(next_leg=True)
        for s in self.r_human.take(N=1000):
            self.human.append((secs(s.header.stamp), s.mode, s.present, s.speed_scale, s.stopped))
            self.heard["human_observer"] = wall
        for _ in self.r_dist.take(N=1000):
            self.heard["fded_distance"] = wall
        if self.now is not None:
            if wall >= self.next_person:
                src, pid, names, poses, vel = self.person
                self.w_skeleton.write(Skeleton(header(self.now), src, pid, names, poses, vel))
                self.next_person = wall + 1.0 / 30.0
            # A shuttle command nobody reported on for 1 s is sent again (a restarted
            # ds_controller has forgotten it).
            if self.goals is not None and wall - self.sent_at > 1.0 and wall - self.acked > 1.0:
                self.send_shuttle(next_leg=False)

    def run_for(self, seconds, each=None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.poll()
            if each is not None:
                each()
            time.sleep(0.001)

    def send_shuttle(self, next_leg):
        if next_leg or self.shuttle_id == 0:
            self.shuttle_id += 1
        g = self.goals[self.shuttle_id % 2]
        self.w_motion.write(MotionCommand(
            header(self.now or 0.0), self.shuttle_id, KIND_CONSTANT_SPEED, f"shuttle {self.shuttle_id}", "", [],
            Pose(Point(*g), Quaternion(0.0, 0.0, 0.0, 1.0)), FAR, True, False))
        self.sent_at = time.monotonic()

    # ---- figures over a window of simulated time
    def speeds(self, t0, t1, joint_bound=math.inf):
        """Largest tool speed (m/s) and joint speed (rad/s) over WINDOW_S windows in [t0, t1],
        the median tool speed, the largest joint displacement from t0 (rad), the number of tool
        samples, and how long (s) the tool was over UNSAFE_TOOL and a joint over `joint_bound`."""
        tool = sorted(x for x in self.tool if t0 <= x[0] <= t1)
        vt, j = [], 0
        for i, a in enumerate(tool):
            while j < len(tool) and tool[j][0] < a[0] + WINDOW_S:
                j += 1
            if j >= len(tool):
                break
            b = tool[j]
            vt.append(math.dist(a[1:], b[1:]) / (b[0] - a[0]))
        joints = sorted((x for x in self.joints if t0 <= x[0] <= t1), key=lambda x: x[0])
        vq, j, moved = [], 0, 0.0
        for i, a in enumerate(joints):
            moved = max(moved, max(abs(p - q) for p, q in zip(a[1], joints[0][1])))
            while j < len(joints) and joints[j][0] < a[0] + WINDOW_S:
                j += 1
            if j >= len(joints):
                break
            b = joints[j]
            vq.append(max(abs(p - q) for p, q in zip(a[1], b[1])) / (b[0] - a[0]))
        med = sorted(vt)[len(vt) // 2] if vt else float("nan")
        # How long (s) the tool was over the bound: windows start at every sample (100 Hz).
        over = sum(1 for v in vt if v > UNSAFE_TOOL) * (tool[-1][0] - tool[0][0]) / max(1, len(tool) - 1) if tool else 0.0
        qover = sum(1 for v in vq if v > joint_bound) * (joints[-1][0] - joints[0][0]) / max(1, len(joints) - 1) if joints else 0.0
        return (max(vt) if vt else float("nan"), max(vq) if vq else float("nan"), med, moved, len(tool), over, qover)

    def nodes_alive(self):
        wall = time.monotonic()
        out = []
        for name, pid in self.graph.pids().items():
            up = alive(pid)
            talking = wall - self.heard.get(name, -1e9) < 2.0
            out.append((name, up and talking, up, talking))
        return out


def attacks(peer):
    """(name, expected to be resisted, per-iteration action) for each attack class."""
    rnd = random.Random(19)
    now = lambda: peer.now or 0.0  # noqa: E731
    big = "x" * 65536

    def joint_commands():
        # Finite values: lwr_sim obeys them, beyond the joint speed limits saturated.
        cmd = rnd.choice([[0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0], [1e300] * 7])
        peer.w_joint_cmd.write(Float64MultiArray(MultiArrayLayout([], 0), cmd))
        return 1

    def joint_commands_malformed():
        bad = rnd.choice([[math.nan] * 7, [math.inf] * 7, [-math.inf] * 7, [], [1.0] * 100, [0.5] * 6,
                          [0.0, math.nan, 0.0, 0.0, 0.0, 0.0, 0.0]])
        peer.w_joint_cmd.write(Float64MultiArray(MultiArrayLayout([], 0), bad))
        return 1

    def distances():
        z = Point(0.0, 0.0, 0.0)
        v = Vector3(0.0, 0.0, 0.0)
        choice = rnd.randrange(5)
        if choice == 0:
            links = []
        elif choice == 1:
            links = [LinkDistance(n, math.nan, z, z, Vector3(0.0, 0.0, 1.0), v, True) for n in LINKS]
        elif choice == 2:
            links = [LinkDistance(n, 5.0, z, z, v, v, True) for n in LINKS]  # zero normal
        elif choice == 3:
            links = [LinkDistance(n, 5.0, z, z, Vector3(0.0, 0.0, 1.0), Vector3(math.inf, 0.0, 0.0), True) for n in LINKS]
        else:
            links = [LinkDistance("elbow", 5.0, z, z, Vector3(0.0, 0.0, 1.0), v, True)] * 7
        peer.w_dist.write(LinkDistances(header(now()), links, 0, 0.0, "stranger"))
        return 1

    def human_absent():
        # Nobody there, far, full speed: what a peer would say to make the arm hurry.
        z = Point(0.0, 0.0, 0.0)
        peer.w_human.write(HumanState(header(now()), 0, False, 0.0, z, Vector3(0.0, 0.0, 0.0), FAR, False))
        return 1

    def human_malformed():
        z = Point(0.0, 0.0, 0.0)
        mode, scale, st = rnd.choice([(7, FAR, False), (0, math.nan, False), (0, 1e9, False), (1, -1.0, False)])
        s = now() + rnd.choice([0.0, 1000.0, -1000.0])
        peer.w_human.write(HumanState(header(s), mode, True, math.nan, z, Vector3(math.nan, 0.0, 0.0), scale, st))
        return 1

    def speech():
        word = rnd.choice(["repeat", "teach", "done", "gripper open", "gripper close", "human take(cup)",
                           "r\u00e9p\u00e9ter \u2603", "", big, "repeat " * 1000])
        peer.w_speech.write(String(word))
        return 1

    def dmp():
        goal = Pose(Point(0.5, 0.0, 0.4), Quaternion(0.0, 0.0, 0.0, 1.0))
        bodies = ["", "{", "[]", "null", '{"kind": "dmp"}', '{"kind": "dmp", "dim": 3, "weights": [1e308, NaN]}',
                  '{"kind": "dmp", "n_basis": 4000000000, "dim": 3}', "[" * 100000, '{"kind": "gmr", "priors": []}',
                  '{"kind": "dmp", "dim": 3, "tau": -1, "k": 70, "d": 16.7, "weights": []}', big]
        peer.w_motion.write(MotionCommand(header(now()), 900000 + rnd.randrange(1000), rnd.choice([2, 3, 4, 9, 255]),
                                          "stranger", rnd.choice(bodies), [rnd.choice([math.nan, 1e308, -1.0])],
                                          goal, rnd.choice([FAR, 1e9, math.nan, -1.0]), False, True))
        return 1

    def model_file():
        name = rnd.choice(["/dev/zero", "/dev/urandom", "/proc/self/mem", "../../../../dev/zero", "../config/ds_controller.yaml",
                           "/etc/shadow", "a/../../b", "", "\u0000", "x" * 5000, "/proc/self/fd/0", "."])
        goal = Pose(Point(0.5, 0.0, 0.4), Quaternion(0.0, 0.0, 0.0, 1.0))
        peer.w_motion.write(MotionCommand(header(now()), 910000 + rnd.randrange(1000), KIND_DMP, "stranger",
                                          json.dumps({"model_file": name}), [], goal, FAR, False, False))
        return 1

    def clock_jumps():
        s = now() + rnd.choice([1000.0, -1000.0, 0.5, -0.5, 2.0e9])
        if rnd.random() < 0.2:
            s = 0.0
        peer.w_clock.write(Clock(stamp(s)))
        return 1

    def wrong_types():
        n = 0
        for w in peer.w_wrong.values():
            w.write(String(rnd.choice(["", "x", big[: rnd.randrange(1, 4096)], "\u00ff" * 100])))
            n += 1
        return n

    # Direct joint commands last: they drive the arm to another configuration (joints on their
    # limits), where the shuttle needs other joint speeds than the baseline measured; classes
    # judged after it got "through" on joint speed alone (CI of stop 28: 0.905 rad/s over a
    # 0.825 bound with the tool at 0.047 m/s).
    return [
        ("malformed joint commands (NaN/inf/size)", True, joint_commands_malformed, 500),
        ("empty/NaN/bad distances", True, distances, 200),
        ("human state: present false, far", True, human_absent, 200),
        ("human state: bad mode/NaN/stamp jumps", True, human_malformed, 200),
        ("speech flood", True, speech, 500),
        ("malformed DMP / learned commands", True, dmp, 50),
        ("model_file tricks", True, model_file, 50),
        ("/clock jumps", True, clock_jumps, 200),
        ("wrong types on 8 topics", True, wrong_types, 100),
        ("direct joint commands", False, joint_commands, 500),
    ]


def scene_320(root, out):
    """The stacking scene with a 320 x 240 camera (the same pin-hole camera, half the pixels per
    axis), so that fDED keeps the controller's watchdog fed on a loaded 2-core machine."""
    swap = {"width: 640": "width: 320", "height: 480": "height: 240", "fx: 525.0": "fx: 262.5",
            "fy: 525.0": "fy: 262.5", "cx: 319.5": "cx: 159.5", "cy: 239.5": "cy: 119.5"}
    lines = []
    with open(os.path.join(root, "config/scenes/stacking-hri.yaml")) as f:
        for line in f:
            key = line.strip()
            lines.append(line.replace(key, swap[key]) if key in swap else line)
    with open(out, "w") as f:
        f.writelines(lines)
    return out


def start_task(peer):
    """Waits for the graph (clock, tool pose, every node heard, the person seen: interaction) and
    starts the shuttle. Returns an error text or None."""
    deadline = time.monotonic() + 60.0
    while True:
        peer.poll()
        up = all(n in peer.heard for n in ("clock", "world", *Graph.NODES))
        if up and peer.human and peer.human[-1][1] == 1 and peer.tool:
            break
        if time.monotonic() > deadline:
            return f"graph not up within 60 s: heard {sorted(peer.heard)}, last human state {peer.human[-1:]}"
        time.sleep(0.002)
    _, x, y, z = peer.tool[-1]
    peer.goals = [(x, y - SHUTTLE_HALF_M, z), (x, y + SHUTTLE_HALF_M, z)]
    peer.send_shuttle(next_leg=True)
    peer.run_for(1.0)
    return None


def stranger(peer, only):
    """The attack classes; returns (failures, rows)."""
    # The baseline; once more when the first window was held (a graph just up on a loaded
    # machine: the controller held on a 0.305 s old first fDED frame for most of it, a clean-clone
    # rehearsal 2026-12-03). The check itself is unchanged.
    for attempt in range(2):
        t0 = peer.now
        peer.run_for(BASELINE_S)
        base = peer.speeds(t0, peer.now)
        print(f"baseline (person standing close, interaction, shuttle at alpha_h {INTERACTION} m/s): "
              f"max tool {base[0]:.3f} m/s, median tool {base[2]:.3f} m/s, max joint {base[1]:.3f} rad/s, {base[4]} world samples")
        # The leg turnarounds show single windows a little over UNSAFE_TOOL (0.14 m/s): judged
        # as the attacks are, by the time over it.
        if base[2] > 0.5 * INTERACTION or base[5] >= SUSTAINED_S:
            break
    if not (base[2] > 0.5 * INTERACTION and base[5] < SUSTAINED_S):
        return [f"the undisturbed shuttle is not moving at about {INTERACTION} m/s (median {base[2]:.3f}, max {base[0]:.3f}, "
                f"{base[5]:.2f} s over {UNSAFE_TOOL:.3f} m/s)"]
    # Joint speeds along the same tool path vary with where the person stands relative to the
    # links (the damper) and with holds and resumes: undisturbed classes reached 1.35 x the
    # baseline's 4 s maximum (2026-12-03); 1.5 x + 0.1 rad/s leaves room for that.
    joint_bound = base[1] * 1.5 + 0.1

    rows = []
    failed = []
    for name, resisted, act, rate in attacks(peer):
        if only and only not in name:
            continue
        t_a = peer.now
        sent = 0
        period = 1.0 / rate
        next_at = [time.monotonic()]

        def each():
            nonlocal sent
            while time.monotonic() >= next_at[0]:
                sent += act()
                next_at[0] += period

        peer.run_for(ATTACK_S, each)
        t_b = peer.now
        vmax, qmax, vmed, moved, _, over, qover = peer.speeds(t_a, t_b + 0.3, joint_bound)
        # Back to the task: a new shuttle leg (an attack may have replaced the command).
        peer.send_shuttle(next_leg=True)
        peer.run_for(RECOVER_S)
        nodes = peer.nodes_alive()
        dead = [n for n, ok, _, _ in nodes if not ok]
        # Sustained: a single 0.1 s window a little over the bound is seen at class boundaries
        # without any attack getting through (a shuttle leg restarting after a hold); a joint
        # likewise (the link damper's and the null-space avoidance's reactions to the person
        # standing close give short joint-speed peaks: 1.15 rad/s with the tool held, 2026-12-03).
        unsafe = over >= SUSTAINED_S or qover >= SUSTAINED_S
        changed = unsafe or abs(vmed - base[2]) > 0.3 * base[2]
        held = sum(1 for s in peer.statuses if t_a <= s[0] <= t_b and s[2] in (STATE_HELD, STATE_ABORTED))
        rows.append((name, sent, len(nodes) - len(dead), len(nodes), vmax, vmed, over, qmax, qover, held, changed, unsafe))
        if dead:
            failed.append(f"{name}: node(s) down after it: {dead}")
        if unsafe and resisted:
            failed.append(f"{name}: got through (tool {vmax:.3f} m/s, joint {qmax:.3f} rad/s)")

    print()
    print(f"{'attack class':42} {'sent':>6} {'alive':>6} {'max tool m/s':>12} {'median':>7} {'s over':>6} {'max joint rad/s':>15} {'s over':>6} "
          f"{'held/aborted':>12} {'changed':>7} {'got through':>11}")
    for name, sent, up, n, vmax, vmed, over, qmax, qover, held, changed, unsafe in rows:
        print(f"{name:42} {sent:>6} {up:>3}/{n:<2} {vmax:>12.3f} {vmed:>7.3f} {over:>6.2f} {qmax:>15.3f} {qover:>6.2f} {held:>12} "
              f"{'yes' if changed else 'no':>7} {'YES' if unsafe else 'no':>11}")
    print(f"got through: tool over {UNSAFE_TOOL:.3f} m/s (interaction speed + 30 %) for {SUSTAINED_S} s or more, or a joint "
          f"> {joint_bound:.3f} rad/s (baseline x 1.5 + 0.1) for as long; {sum(r[1] for r in rows)} messages in all")
    if os.environ.get("STRANGER_DUMP"):
        with open(os.environ["STRANGER_DUMP"], "w") as f:
            json.dump({"joints": peer.joints, "tool": peer.tool, "statuses": peer.statuses}, f)
    through = [r[0] for r in rows if r[-1]]
    print(f"got through: {through or 'none'} (direct joint commands need DDS security to refuse)")
    return failed


def chaos_case(peer, node, fault, down_s):
    """One fault of `node` during the shuttle: `kill` (SIGKILL, restarted after `down_s`) or
    `stop` (SIGSTOP, SIGCONT after `down_s`). Returns the figures, all from the simulated world:
    time to hold (s from the fault until the tool stays below 1 cm/s), tool path and largest
    joint displacement after the fault, time to resume (s from restart / SIGCONT until the tool
    moves at half the interaction speed), shuttle legs converged within 10 s after."""
    peer.run_for(1.5)  # moving
    t_f = peer.now
    debug = os.environ.get("STRANGER_LOGS")
    if debug:
        print(f"chaos {fault} {node}: fault at wall {time.time():.3f}, sim {t_f:.3f}", flush=True)
    peer.graph.signal(node, signal.SIGKILL if fault == "kill" else signal.SIGSTOP)
    peer.run_for(down_s)
    t_r = peer.now
    if fault == "kill":
        peer.graph.start(node)
    else:
        peer.graph.signal(node, signal.SIGCONT)
    wall_r = time.monotonic()
    resumed = None
    while time.monotonic() - wall_r < 10.0:
        peer.run_for(0.2)
        sp = [v for v in window_speeds(peer.tool, t_r, peer.now) if v[1] > 0.5 * INTERACTION]
        if sp and resumed is None:
            resumed = sp[0][0] - t_r
        if resumed is not None and any(c > t_r + resumed for c in peer.converged):
            break
    t_end = peer.now
    if debug:
        print(f"chaos {fault} {node}: back at sim {t_r:.3f}, end at wall {time.time():.3f}, sim {t_end:.3f}", flush=True)
    win = window_speeds(peer.tool, t_f, t_r)
    held_at = None
    for k in range(len(win)):
        if all(v < 0.01 for _, v in win[k:]):
            held_at = win[k][0] - t_f
            break
    path = 0.0
    tool = sorted(x for x in peer.tool if t_f <= x[0] <= t_r)
    for a, b in zip(tool, tool[1:]):
        path += math.dist(a[1:], b[1:])
    joints = sorted((x for x in peer.joints if t_f <= x[0] <= t_r), key=lambda x: x[0])
    moved = max((max(abs(p - q) for p, q in zip(j[1], joints[0][1])) for j in joints), default=float("nan"))
    legs = sum(1 for c in peer.converged if t_r < c <= t_end)
    down = [f"{n}{'' if up else ' (exited)'}{'' if talking else ' (silent)'}" for n, ok, up, talking in peer.nodes_alive() if not ok]
    return held_at, path, moved, resumed, legs, down


def window_speeds(tool_samples, t0, t1):
    """(t, tool speed m/s) over WINDOW_S windows of the tool samples in [t0, t1]."""
    tool = sorted(x for x in tool_samples if t0 <= x[0] <= t1)
    out, j = [], 0
    for a in tool:
        while j < len(tool) and tool[j][0] < a[0] + WINDOW_S:
            j += 1
        if j >= len(tool):
            break
        b = tool[j]
        out.append((a[0], math.dist(a[1:], b[1:]) / (b[0] - a[0])))
    return out


def chaos(peer, cases):
    rows, failed = [], []
    for node, fault, down in cases:
        held, path, moved, resumed, legs, ok = chaos_case(peer, node, fault, down)
        rows.append((node, fault, down, held, path, moved, resumed, legs, ok))
        what = f"{fault} {node}"
        if held is None:
            failed.append(f"{what}: the robot was not held within {down} s")
        if resumed is None or legs == 0:
            failed.append(f"{what}: the task did not resume (resumed {resumed}, legs {legs})")
        if ok:
            failed.append(f"{what}: node(s) down after it: {ok}")
    print()
    print(f"{'fault':30} {'down s':>6} {'to hold s':>9} {'tool path m':>11} {'joint max rad':>13} {'to resume s':>11} "
          f"{'legs after':>10} {'alive':>5}")
    fmt = lambda v, f: "never" if v is None else format(v, f)  # noqa: E731
    for node, fault, down, held, path, moved, resumed, legs, ok in rows:
        print(f"{fault + ' ' + node:30} {down:>6.1f} {fmt(held, '9.3f'):>9} {path:>11.4f} {moved:>13.4f} "
              f"{fmt(resumed, '11.3f'):>11} {legs:>10} {'NO' if ok else 'yes':>5}")
    return failed


LOCKS = os.environ.get("COWORK_DOMAIN_LOCKS") or "/tmp/cowork-dds-domains"


def leased_by(pid):
    """The DDS domains process PID holds a lease on now (cowork_ros::domain: a held flock on
    LOCKS/<N>.lease whose text ends with `(pid PID)`), in order."""
    import fcntl
    found = []
    try:
        names = os.listdir(LOCKS)
    except OSError:
        return found
    for name in names:
        if not name.endswith(".lease"):
            continue
        path = os.path.join(LOCKS, name)
        try:
            with open(path) as f:
                if not f.read().strip().endswith(f"(pid {pid})"):
                    continue
                try:
                    fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
                    fcntl.flock(f, fcntl.LOCK_UN)
                    continue  # not held: a stale text
                except OSError:
                    found.append(int(name[:-len(".lease")]))
        except (OSError, ValueError):
            continue
    return sorted(found)


class Domains:
    """The domains to attack: a fixed list, or (with the pid of a `cowork experiment` run) those
    it holds leases on, looked up again each second so its execution domain, leased after the
    teaching, is attacked too."""

    def __init__(self, domain, pid=None):
        self.pid, self.next = pid, 0.0
        self.known, self.pending = [], ([] if pid else [domain])

    def new(self):
        """Domains not returned before."""
        if self.pid is not None and time.monotonic() >= self.next:
            self.next = time.monotonic() + 1.0
            self.pending += [d for d in leased_by(self.pid) if d not in self.known and d not in self.pending]
        fresh, self.pending = self.pending, []
        self.known += fresh
        return fresh


def flood(domains, seconds):
    """Mode `flood SECONDS [PID]`: no graph of its own; drives whatever graph runs on the
    domains (the given one, or those the `cowork experiment` with process id PID holds leases
    on, teaching and then execution: see `Domains`) with
    direct joint commands (0.5 rad/s on joints 1 and 2) at 100 Hz, the one attack that gets
    through without DDS security. For a secured graph against the same attack
    (tests/reliability/secured_graph.sh). Prints how many it sent."""
    qos = Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=5)),
        Policy.History.KeepLast(100),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )
    writers = []
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    sent, end = 0, time.monotonic() + seconds
    while time.monotonic() < end and not stop:
        for d in domains.new():
            dp = DomainParticipant(d)
            writers.append((dp, DataWriter(dp, Topic(dp, "rt/lwr/joint_velocity_command", Float64MultiArray), qos=qos)))
        for _, w in writers:
            w.write(Float64MultiArray(MultiArrayLayout([], 0), [0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0]))
        sent += 1
        time.sleep(0.01)
    print(f"flood: {sent} direct joint commands sent on each of domains {domains.known}", flush=True)
    return 0


def assault(domains, seconds, only):
    """Mode `assault SECONDS [PID]`: every attack class of the stranger check in turn, ATTACK_S
    each at its rate, blind (it cannot watch a secured graph), on the domains `flood` names,
    until SECONDS or SIGTERM. The trial it attacks judges itself from the simulated world
    (tests/reliability/secured_graph.sh with ATTACK=assault). Prints what it sent per class and
    how many /clock messages of the graph it could read."""
    attackers, per, classes, sent = [], [], [], {}
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    end = time.monotonic() + seconds
    while time.monotonic() < end and not stop:
        fresh = domains.new()
        if fresh:
            attackers += [Attacker(d) for d in fresh]
            per += [attacks(a) for a in attackers[-len(fresh):]]
            classes = [(rows[0][0], rows[0][3], [r[2] for r in rows])
                       for rows in zip(*per) if not only or only in rows[0][0]]
            for name, _, _ in classes:
                sent.setdefault(name, 0)
        if not classes:
            time.sleep(0.2)
            continue
        for name, rate, acts in classes:
            next_at = time.monotonic()
            until = min(end, next_at + ATTACK_S)
            while time.monotonic() < until and not stop:
                while time.monotonic() >= next_at:
                    for act in acts:
                        sent[name] += act()
                    next_at += 1.0 / rate
                for a in attackers:
                    a.poll()
                time.sleep(0.001)
            if stop or time.monotonic() >= end:
                break
    print(f"assault on domains {domains.known}: {sum(sent.values())} messages; the graph's /clock read "
          f"{[a.clocks for a in attackers]} times")
    for name, n in sent.items():
        print(f"  {name:42} {n:>7}")
    return 0


SECURITY_VARS = ("ROS_SECURITY_ENABLE", "ROS_SECURITY_STRATEGY", "ROS_SECURITY_KEYSTORE", "ROS_SECURITY_ENCLAVE_OVERRIDE")


def secure(domain, root, bin_dir):
    """Mode `secure`: DDS Security against this peer, which has no credentials.

    A keystore from `cowork keystore create` with enclaves `listener` and `talker`; two cowork
    processes (`secure_peer`, built with `--features security`) on `/speech_command`, the
    listener counting what arrives per sender, the talker (a graph member) at 100 Hz; this
    Cyclone DDS peer floods `/speech_command` at 100 Hz meanwhile. Run twice: without security
    (the stranger's messages arrive: the check can fail) and with ROS_SECURITY_STRATEGY=Enforce
    (the goal: 0 through, while the member still gets through).
    """
    cowork = os.path.join(bin_dir, "cowork")
    peer_bin = os.environ.get("SECURE_PEER", os.path.join(bin_dir, "examples", "secure_peer"))
    for b in (cowork, peer_bin):
        if not os.access(b, os.X_OK):
            return [f"{b} missing (cargo build --release -p cowork; cargo build --release -p cowork_ros --features security --example secure_peer)"]
    ks = os.path.join(tempfile.mkdtemp(prefix="cowork-keystore-"), "keystore")
    subprocess.run([cowork, "keystore", "create", ks], check=True, cwd=root)
    subprocess.run([cowork, "keystore", "enclave", ks, "listener", "talker"], check=True, cwd=root)
    qos = Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=5)),
        Policy.History.KeepLast(2000),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )
    failed = []
    print("| run | stranger sent | stranger through | member sent | member through |")
    print("|---|---|---|---|---|")
    for secured in (False, True):
        env = {k: v for k, v in os.environ.items() if k not in SECURITY_VARS}
        env["ROS_DOMAIN_ID"] = str(domain)
        if secured:
            env.update(ROS_SECURITY_ENABLE="true", ROS_SECURITY_STRATEGY="Enforce", ROS_SECURITY_KEYSTORE=ks)
        pipe = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=root)
        listener = subprocess.Popen([peer_bin, "listen", "/speech_command", "11"],
                                    env=dict(env, ROS_SECURITY_ENCLAVE_OVERRIDE="/listener"), **pipe)
        talker = subprocess.Popen([peer_bin, "talk", "/speech_command", "member", "8"],
                                  env=dict(env, ROS_SECURITY_ENCLAVE_OVERRIDE="/talker"), **pipe)
        time.sleep(2.0)
        dp = DomainParticipant(domain)
        writer = DataWriter(dp, Topic(dp, "rt/speech_command", String), qos=qos)
        sent = 0
        end = time.time() + 6.0
        while time.time() < end:
            writer.write(String(data=f"stranger {sent}"))
            sent += 1
            time.sleep(0.01)
        del writer, dp
        l_out, l_err = listener.communicate(timeout=60)
        t_out, t_err = talker.communicate(timeout=60)
        try:
            got = json.loads(l_out.strip().splitlines()[-1])["received"]
            member_sent = json.loads(t_out.strip().splitlines()[-1])["sent"]
        except (IndexError, ValueError, KeyError):
            failed.append(f"secure_peer failed (security {'on' if secured else 'off'}):\n{l_err}\n{t_err}")
            continue
        through, member = got.get("stranger", 0), got.get("member", 0)
        name = "Enforce (keystore, enclaves listener + talker)" if secured else "no security"
        print(f"| {name} | {sent} | {through} | {member_sent} | {member} |")
        if secured:
            print(f"with security: {sent} sent, {through} through")
            if through:
                failed.append(f"with security {through} of the stranger's {sent} messages got through")
            if member == 0:
                failed.append("with security the member's messages did not arrive either (security broken, not enforced)")
        elif through == 0:
            failed.append("without security nothing of the stranger arrived: the check cannot tell")
    return failed


def main():
    args = sys.argv[1:]
    domain = int(args.pop(0))
    mode = args.pop(0) if args else "check"  # check | chaos
    only = os.environ.get("STRANGER_ONLY")
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "../.."))
    bin_dir = os.path.join(root, os.environ.get("BIN", "target/release"))
    if mode in ("flood", "assault"):
        seconds = float(args.pop(0)) if args else 60.0
        # With the pid of a `cowork experiment` run: the domains it leases, as it leases them.
        domains = Domains(domain, int(args.pop(0)) if args else None)
        return flood(domains, seconds) if mode == "flood" else assault(domains, seconds, only)
    if mode == "secure":
        failed = secure(domain, root, bin_dir)
        for f in failed:
            print("FAIL:", f)
        if not failed:
            print("OK: with DDS security the stranger got nothing through, the member did")
        return 1 if failed else 0
    logs = tempfile.mkdtemp(prefix="cowork-stranger-")
    graph = Graph(domain, root, bin_dir, scene_320(root, os.path.join(logs, "scene.yaml")), logs)
    failed = []
    try:
        peer = Peer(domain, graph)
        err = start_task(peer)
        if err:
            failed.append(err)
        elif mode == "chaos":
            cases = [(n, f, 2.0) for n in ("fded_distance", "human_observer", "ds_controller") for f in ("stop", "kill")]
            failed += chaos(peer, [c for c in cases if not only or only in c[0]])
        else:
            failed += stranger(peer, only)
            # The direct joint commands leave the arm off the shuttle's line (up to 2 rad/s for
            # 3 s); the chaos case starts from a running shuttle, so first the task is back: a
            # leg converged (the chaos case's "legs after" saw none within 10 s otherwise).
            wall = time.monotonic()
            legs = len(peer.converged)
            while len(peer.converged) == legs and time.monotonic() - wall < 40.0:
                peer.run_for(0.2)
            back = len(peer.converged) > legs
            print(f"after the attacks: {'a shuttle leg converged' if back else 'no shuttle leg converged'} "
                  f"{time.monotonic() - wall:.1f} s later")
            if not back:
                failed.append("the shuttle did not come back within 40 s after the attacks")
            # The short chaos cases: fded_distance stopped, continued 1.5 s later (RustDDS ends
            # its threads on the EINTR this gives; node_main restarts the node), then killed and
            # restarted 1.5 s later.
            failed += chaos(peer, [("fded_distance", "stop", 1.5), ("fded_distance", "kill", 1.5)])
    finally:
        graph.stop()
        if failed or os.environ.get("STRANGER_LOGS"):
            print(graph.tail())
    for f in failed:
        print("FAIL:", f)
    if not failed:
        print("OK: 0 crashes, no unsafe motion but the direct joint commands" if mode != "chaos" else "OK: every fault held the robot and the task resumed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
