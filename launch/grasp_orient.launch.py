"""Starts the grasp_orient node with the package's parameters.

    ros2 launch grasp_orient grasp_orient.launch.py [params_file:=/path/to/params.yaml]

Beside a MoveIt 2 / ros2_control stack (docs/moveit.md), e.g.:

    ros2 launch grasp_orient grasp_orient.launch.py gravity_frame:=world \\
        objects_file:=/path/to/objects.yaml gripper_action:=/gripper_controller/gripper_cmd \\
        planning_scene_topic:=/monitored_planning_scene

gravity_frame, objects_file and gripper_action, when given (not empty), set those parameters over the
params file's; left empty, the params file's values hold. collision_object_topic and planning_scene_topic
remap the node's /collision_object and /planning_scene subscriptions: move_group publishes the scene it
keeps, every change from any client included, on /monitored_planning_scene.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

# Launch arguments that set the node's parameter of the same name when not empty.
PARAMETER_ARGUMENTS = {
    "gravity_frame": "TF frame in which gravity is the parameter gravity (default (0, 0, -9.80665)), e.g. world",
    "objects_file": "YAML file of the objects' mass and friction by CollisionObject id",
    "gripper_action": "control_msgs/action/GripperCommand server ~/grip sends the grip force to, "
                      "e.g. /gripper_controller/gripper_cmd",
}
# Launch arguments naming the topic each of the node's MoveIt subscriptions is remapped to.
REMAP_ARGUMENTS = {
    "collision_object_topic": ("/collision_object", "topic of moveit_msgs/CollisionObject the node listens to"),
    "planning_scene_topic": ("/planning_scene", "topic of moveit_msgs/PlanningScene the node listens to; "
                                                "move_group's own scene: /monitored_planning_scene"),
}


def grasp_orient_node(context):
    overrides = {}
    for name in PARAMETER_ARGUMENTS:
        value = LaunchConfiguration(name).perform(context)
        if value:
            overrides[name] = value
    remappings = []
    for name, (topic, _) in REMAP_ARGUMENTS.items():
        to = LaunchConfiguration(name).perform(context)
        if to and to != topic:
            remappings.append((topic, to))
    params_file = LaunchConfiguration("params_file").perform(context)
    return [
        Node(
            package="grasp_orient",
            executable="grasp_orient",
            name="grasp_orient",
            arguments=["node"],
            parameters=[params_file, overrides] if overrides else [params_file],
            remappings=remappings,
            output="screen",
        )
    ]


def generate_launch_description():
    default_params = os.path.join(
        get_package_share_directory("grasp_orient"), "config", "grasp_orient.yaml"
    )
    arguments = [
        DeclareLaunchArgument(
            "params_file",
            default_value=default_params,
            description="ROS 2 params file for the grasp_orient node",
        )
    ]
    arguments += [
        DeclareLaunchArgument(name, default_value="", description=text)
        for name, text in PARAMETER_ARGUMENTS.items()
    ]
    arguments += [
        DeclareLaunchArgument(name, default_value=topic, description=text)
        for name, (topic, text) in REMAP_ARGUMENTS.items()
    ]
    return LaunchDescription([*arguments, OpaqueFunction(function=grasp_orient_node)])
