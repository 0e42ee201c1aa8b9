"""ROS 2 launch file for users with a ROS 2 installation.

    ros2 launch launch_scripts/cowork.launch.py [rate:=1.0] [scene:=config/scenes/kitchen.yaml]

Run from the repository root after `cargo build --release --bins`. The nodes are plain
executables (not colcon packages), so they are started with ExecuteProcess. By default cowork
keeps DDS on loopback; export ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET to reach other hosts.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release")


def node(name, *args):
    return ExecuteProcess(
        cmd=[os.path.join(BIN, name), *args],
        cwd=ROOT,
        name=name,
        output="screen",
        sigterm_timeout="5",
    )


def generate_launch_description():
    rate = LaunchConfiguration("rate")
    scene = LaunchConfiguration("scene")
    return LaunchDescription(
        [
            DeclareLaunchArgument("rate", default_value="1.0", description="simulated s per wall s"),
            DeclareLaunchArgument(
                "scene", default_value="config/scenes/kitchen.yaml", description="scene file"
            ),
            node("lwr_sim", "--rate", rate, "--scene", scene),
            node("fded_distance", "--params", "config/fded_distance.yaml", "--use-sim-time"),
            node("human_observer", "--params", "config/human_observer.yaml", "--use-sim-time"),
            node("ds_controller", "--params", "config/ds_controller.yaml", "--use-sim-time"),
            node(
                "robot_manager",
                "--params",
                "config/robot_manager.yaml",
                "--use-sim-time",
                "--database-dir",
                "out/primitives",
            ),
            node("attentional_supervisor", "--ltm", "config/tasks/kitchen.schema", "--task", "pourDrink"),
        ]
    )
