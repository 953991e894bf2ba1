"""Starts the grasp_orient node with the package's parameters.

    ros2 launch grasp_orient grasp_orient.launch.py [params_file:=/path/to/params.yaml]
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    default_params = os.path.join(
        get_package_share_directory("grasp_orient"), "config", "grasp_orient.yaml"
    )
    params_file = LaunchConfiguration("params_file")
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "params_file",
                default_value=default_params,
                description="ROS 2 params file for the grasp_orient node",
            ),
            Node(
                package="grasp_orient",
                executable="grasp_orient",
                name="grasp_orient",
                arguments=["node"],
                parameters=[params_file],
                output="screen",
            ),
        ]
    )
