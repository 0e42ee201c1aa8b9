"""ROS 2 launch file for users with a ROS 2 installation.

    ros2 launch launch_scripts/cowork.launch.py [rate:=1.0] [scene:=config/scenes/kitchen.yaml]
        [execute:=TASK [learned:=config/learned]] [task:=pourDrink]

execute:=TASK carries out TASK (pourDrink, prepareCoffee, ...) with the LTM and a copy of the
primitive database learned in `learned` (written by launch_scripts/teach.sh), as
`launch_scripts/graph.sh --execute TASK`; without it the supervisor waits to be taught `task`.

Run from the repository root after `cargo build --release --bins`. The nodes are plain
executables (not colcon packages), so they are started with ExecuteProcess. By default cowork
keeps DDS on loopback; export ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET to reach other hosts.

One graph per DDS domain on a machine: the launch holds the lease of ROS_DOMAIN_ID (default 0)
for its life, as every cowork launcher does (`cowork domain list`), and refuses a domain another
graph holds, naming it.
"""

import fcntl
import os
import shutil

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
from launch.substitutions import LaunchConfiguration

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release")


_LEASE = []  # the open lease file: held while the launch runs


def lease_domain():
    """Takes the lease of ROS_DOMAIN_ID as cowork_ros::domain does: an exclusive flock on
    <locks>/<N>.lease, refused when held or when cowork nodes run on the domain (<N>.members)."""
    domain = int(os.environ.get("ROS_DOMAIN_ID", "").strip() or 0)
    locks = os.environ.get("COWORK_DOMAIN_LOCKS") or "/tmp/cowork-dds-domains"
    os.makedirs(locks, mode=0o1777, exist_ok=True)
    lease = open(os.path.join(locks, f"{domain}.lease"), "a+")
    try:
        fcntl.flock(lease, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lease.seek(0)
        holder = lease.read().strip() or "holder unknown"
        raise RuntimeError(f"DDS domain {domain} is taken by another graph ({holder}); choose another ROS_DOMAIN_ID")
    with open(os.path.join(locks, f"{domain}.members"), "a+") as members:
        try:
            fcntl.flock(members, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise RuntimeError(f"DDS domain {domain} already has cowork nodes running on it; stop them or choose another ROS_DOMAIN_ID")
    lease.seek(0)
    lease.truncate()
    lease.write(f"ros2 launch cowork.launch.py (pid {os.getpid()})\n")
    lease.flush()
    _LEASE.append(lease)


def node(name, *args):
    return ExecuteProcess(
        cmd=[os.path.join(BIN, name), *args],
        cwd=ROOT,
        name=name,
        output="screen",
        sigterm_timeout="5",
    )


def manager_and_supervisor(context):
    """robot_manager + attentional_supervisor, teaching or executing (resolved at launch time)."""
    execute = LaunchConfiguration("execute").perform(context)
    learned = os.path.join(ROOT, LaunchConfiguration("learned").perform(context))
    if execute:
        ltm = os.path.join(learned, "kitchen.learned.schema")
        if not (os.path.isfile(ltm) and os.path.isfile(os.path.join(learned, "primitives", "lwr.primitives.json"))):
            raise RuntimeError(f"nothing learned in {learned}: run launch_scripts/teach.sh (or give learned:=DIR)")
        work = os.path.join(ROOT, "out", "execute")
        shutil.rmtree(work, ignore_errors=True)
        database = os.path.join(work, "primitives")
        shutil.copytree(os.path.join(learned, "primitives"), database)
        task, save = execute, os.path.join(work, "kitchen.learned.schema")
    else:
        save = os.path.join(ROOT, "out", "kitchen.learned.schema")
        ltm = save if os.path.isfile(save) else os.path.join(ROOT, "config", "tasks", "kitchen.schema")
        database = os.path.join(ROOT, "out", "primitives")
        task = LaunchConfiguration("task").perform(context)
    return [
        node("robot_manager", "--params", "config/robot_manager.yaml", "--use-sim-time", "--database-dir", database),
        node("attentional_supervisor", "--ltm", ltm, "--task", task, "--use-sim-time", "--save-ltm", save),
    ]


def generate_launch_description():
    lease_domain()
    rate = LaunchConfiguration("rate")
    scene = LaunchConfiguration("scene")
    return LaunchDescription(
        [
            DeclareLaunchArgument("rate", default_value="1.0", description="simulated s per wall s"),
            DeclareLaunchArgument(
                "scene", default_value="config/scenes/kitchen.yaml", description="scene file"
            ),
            DeclareLaunchArgument("execute", default_value="", description="task to carry out"),
            DeclareLaunchArgument("learned", default_value="config/learned", description="learned LTM + primitives"),
            DeclareLaunchArgument("task", default_value="pourDrink", description="task to teach"),
            node("lwr_sim", "--rate", rate, "--scene", scene),
            node("fded_distance", "--params", "config/fded_distance.yaml", "--use-sim-time"),
            node("human_observer", "--params", "config/human_observer.yaml", "--use-sim-time"),
            node("ds_controller", "--params", "config/ds_controller.yaml", "--use-sim-time"),
            OpaqueFunction(function=manager_and_supervisor),
        ]
    )
