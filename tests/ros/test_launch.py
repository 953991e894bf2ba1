"""launch/grasp_orient.launch.py's arguments (docs/moveit.md#remaps), against the node over Fast DDS.

The launch and launch_ros wheels are not on PyPI, so the launch file runs here on stand-ins of the few names it
imports (LaunchDescription, DeclareLaunchArgument, OpaqueFunction, LaunchConfiguration, Node): its declared
arguments with a user's values give the Node action's parameters and remappings. The node is then started as
launch_ros starts it from those (`--ros-args -r __node:=NAME --params-file FILE ...`, a dict of parameters
written to a params file of its own under `/**`, `-r from:=to` for each remapping; here in a namespace of its
own), and its parameters and subscriptions are read back from the ROS graph: the arguments given set their
parameters over the params file's, those left empty leave the params file's, and the scene topic is remapped
onto move_group's.
"""
from __future__ import annotations

import importlib.util
import sys
import types

import yaml

from conftest import REPO_ROOT

from rcl_interfaces.srv import GetParameters  # noqa: E402

LAUNCH = REPO_ROOT / "launch" / "grasp_orient.launch.py"
NODE_NS = "/launch_case"


class Recorded:
    """A stand-in launch entity: its arguments, kept."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class LaunchConfiguration:
    def __init__(self, name: str):
        self.name = name

    def perform(self, context) -> str:
        return context[self.name]


def evaluate(monkeypatch, **given: str) -> dict:
    """The launch file with `given` launch arguments: the Node action's keyword arguments."""
    modules = {name: types.ModuleType(name) for name in
               ("launch", "launch.actions", "launch.substitutions", "launch_ros", "launch_ros.actions",
                "ament_index_python", "ament_index_python.packages")}
    modules["launch"].LaunchDescription = Recorded
    modules["launch.actions"].DeclareLaunchArgument = Recorded
    modules["launch.actions"].OpaqueFunction = Recorded
    modules["launch.substitutions"].LaunchConfiguration = LaunchConfiguration
    modules["launch_ros.actions"].Node = Recorded
    modules["ament_index_python.packages"].get_package_share_directory = lambda package: str(REPO_ROOT)
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("grasp_orient_launch", LAUNCH)
    assert spec is not None and spec.loader is not None
    launch = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch)
    entities = launch.generate_launch_description().args[0]
    declared = {e.args[0]: e.kwargs["default_value"] for e in entities if "default_value" in e.kwargs}
    assert set(given) <= set(declared), (sorted(given), sorted(declared))
    functions = [e.kwargs["function"] for e in entities if "function" in e.kwargs]
    assert len(functions) == 1, entities
    (node,) = functions[0]({**declared, **given})
    return node.kwargs


def command_line(node: dict, tmp_path) -> list[str]:
    """The node's arguments as launch_ros gives them, in the test's namespace."""
    args = [*node["arguments"], "--ros-args", "-r", f"__node:={node['name']}", "-r", f"__ns:={NODE_NS}"]
    for k, p in enumerate(node["parameters"]):
        if isinstance(p, dict):
            path = tmp_path / f"launch_params_{k}.yaml"
            path.write_text(yaml.safe_dump({"/**": {"ros__parameters": p}}))
            p = str(path)
        args += ["--params-file", p]
    for a, b in node["remappings"]:
        args += ["-r", f"{a}:={b}"]
    return args


def test_the_defaults_start_the_params_file_alone(monkeypatch):
    node = evaluate(monkeypatch)
    assert node["parameters"] == [str(REPO_ROOT / "config" / "grasp_orient.yaml")], node
    assert node["remappings"] == [] and node["arguments"] == ["node"], node


def test_the_moveit_arguments_set_the_parameters_and_remap_the_scene(monkeypatch, start_node, peer, tmp_path):
    given = {"gravity_frame": "world", "objects_file": str(REPO_ROOT / "examples" / "pick_objects.yaml"),
             "gripper_action": "/gripper_controller/gripper_cmd", "planning_scene_topic": "/monitored_planning_scene"}
    node = evaluate(monkeypatch, **given)
    assert node["remappings"] == [("/planning_scene", "/monitored_planning_scene")], node
    args = command_line(node, tmp_path)
    assert args[0] == "node"
    n = start_node(*args[1:], "-p", "record:=false", name="grasp_orient node (launch arguments)")
    get = peer.node.create_client(GetParameters, f"{NODE_NS}/grasp_orient/get_parameters")
    try:
        names = ["gravity_frame", "objects_file", "gripper_action", "objective"]
        values = peer.call(get, GetParameters.Request(names=names), timeout=15.0).values
        got = dict(zip(names, (v.string_value for v in values)))
        # The three given, over the params file's (''); objective, not given, is the params file's.
        assert got == {**{k: given[k] for k in names[:3]}, "objective": "norm2"}, got
        assert peer.spin_until(lambda: ("grasp_orient", NODE_NS) in peer.node.get_node_names_and_namespaces(), 15.0)
        topics = dict(peer.node.get_subscriber_names_and_types_by_node("grasp_orient", NODE_NS))
        assert topics.get("/monitored_planning_scene") == ["moveit_msgs/msg/PlanningScene"], topics
        assert "/planning_scene" not in topics and "/collision_object" in topics, topics
    finally:
        peer.node.destroy_client(get)
        n.stop_and_check()
