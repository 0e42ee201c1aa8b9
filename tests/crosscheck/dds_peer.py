"""Independent DDS peer (Cyclone DDS) against lwr_sim.

Checks that lwr_sim speaks ROS 2 over DDS: /joint_states arrives as
`rt/joint_states` with type `sensor_msgs::msg::dds_::JointState_`, and a
`std_msgs::msg::dds_::Float64MultiArray_` published on `rt/lwr/joint_velocity_command`
moves the simulated joints as commanded. Exits non-zero on any mismatch.
"""

import math
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str
    size: uint32
    stride: uint32


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension]
    data_offset: uint32


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout
    data: sequence[float64]


def fail(msg):
    print(f"FAIL: {msg}")
    sys.exit(1)


def main():
    domain = int(sys.argv[1])
    # ROS 2 (rmw_cyclonedds / rmw_fastrtps) uses classic CDR (XCDR1).
    qos = Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
        Policy.History.KeepLast(10),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )
    dp = DomainParticipant(domain)
    js_topic = Topic(dp, "rt/joint_states", JointState)
    cmd_topic = Topic(dp, "rt/lwr/joint_velocity_command", Float64MultiArray)
    reader = DataReader(dp, js_topic, qos=qos)
    writer = DataWriter(dp, cmd_topic, qos=qos)

    def latest(timeout):
        deadline = time.time() + timeout
        last = None
        while time.time() < deadline:
            for s in reader.take(N=100):
                last = s
            if last is not None:
                return last
            time.sleep(0.01)
        return None

    first = latest(30.0)
    if first is None:
        fail("no /joint_states from lwr_sim within 30 s")
    names = list(first.name)
    print(f"received JointState: names={names} frame_id={first.header.frame_id!r}")
    if len(names) != 7 or len(first.position) != 7 or len(first.velocity) != 7:
        fail(f"expected 7 joints, got names={len(names)} position={len(first.position)}")
    q0 = list(first.position)

    # Command joint 1 at 0.2 rad/s for ~1.5 s (re-sent at 50 Hz, under the 0.1 s command timeout).
    speed = 0.2
    cmd = Float64MultiArray(MultiArrayLayout([], 0), [speed, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    t_start = None
    for _ in range(75):
        writer.write(cmd)
        time.sleep(0.02)
        s = latest(0.0)
        if s is not None and t_start is None and abs(s.position[0] - q0[0]) > 1e-6:
            t_start = s.header.stamp
    time.sleep(0.3)  # the command times out; the robot stops
    last = latest(2.0)
    if last is None:
        fail("/joint_states stopped arriving")
    dq = [a - b for a, b in zip(last.position, q0)]
    print(f"joint displacement after the command: {[round(v, 4) for v in dq]} rad")
    if not (0.1 < dq[0] < 0.6):
        fail(f"joint 1 moved {dq[0]:.4f} rad; expected about {speed} rad/s x 1.5 s = 0.3 rad")
    if max(abs(v) for v in dq[1:]) > 1e-9:
        fail("joints other than joint 1 moved")
    if any(abs(v) > 1e-9 for v in last.velocity):
        fail(f"robot still moving after the command timed out: {list(last.velocity)}")
    if not all(math.isfinite(v) for v in last.position):
        fail("non-finite joint position")
    print("OK: Cyclone DDS peer received /joint_states and moved joint 1 via /lwr/joint_velocity_command")


if __name__ == "__main__":
    main()
