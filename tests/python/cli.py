"""`grasp_orient solve` on JSON lines, and the comparison of its answers with the Python module's
columns, field by field (docs/usage.md: one GripRecommendation or PoseRecommendation a line).

What may differ, and only that: a refusal of the input (status 2) names its line in `solve`
("line 3: ...") and its row in the module ("row 2: ..."); JSON writes a number that is not finite
as null.
"""
from __future__ import annotations

import json
import math
import re
import subprocess
from pathlib import Path

import numpy as np

XYZ = ("x", "y", "z")
XYZW = ("x", "y", "z", "w")
# Each column of the module's answer, and how the same field reads in a GripRecommendation line.
VECTOR_FIELDS = {"rotation": XYZW, "rotation_axis": XYZ, "gravity_direction": XYZ}
SCALAR_FIELDS = (
    "status", "wrist_rotation", "gravity_angle", "gripping_power", "gripping_power_nominal",
    "internal_force", "finger_force", "gripping_power_current", "internal_force_current",
    "finger_force_current", "candidate_c",
)
TEXT_FIELDS = ("grasp_case", "recommended_label", "objective")
POSE_FIELDS = {"contact_1": XYZ, "contact_2": XYZ, "normal_1": XYZ, "normal_2": XYZ, "center_of_mass": XYZ}


def run_solve(binary: Path, lines: list[dict], *flags: str) -> list[dict]:
    """The answers of `grasp_orient solve FLAGS` to `lines`, one dict each."""
    text = "".join(json.dumps(line) + "\n" for line in lines)
    done = subprocess.run([str(binary), "solve", *flags], input=text, capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, f"grasp_orient solve failed ({done.returncode}): {done.stderr[-2000:]}"
    answers = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    assert len(answers) == len(lines), (len(answers), len(lines), done.stderr[-2000:])
    return answers


def same_number(ours: float, theirs) -> bool:
    """Equal to the last bit; JSON's null stands for a number that is not finite."""
    if theirs is None:
        return not math.isfinite(ours)
    return float(ours) == float(theirs) or (math.isnan(ours) and math.isnan(float(theirs)))


def unprefixed(message: str) -> str:
    """A message without the line (solve's) or the row (the module's) it names."""
    return re.sub(r"^(line \d+|row \d+): ", "", message)


def compare(ours: dict, theirs: list[dict], poses: bool = False) -> int:
    """Asserts that every row of `ours` (the module's columns) is the answer in `theirs` (solve's
    lines), field by field; returns how many values were compared."""
    n = len(theirs)
    assert len(ours["status"]) == n
    compared = 0
    for i, line in enumerate(theirs):
        r = line["recommendation"] if poses else line
        where = f"row {i}"
        for field in SCALAR_FIELDS:
            assert same_number(ours[field][i], r[field]), (where, field, ours[field][i], r[field])
            compared += 1
        for field, keys in VECTOR_FIELDS.items():
            for k, key in enumerate(keys):
                assert same_number(ours[field][i, k], r[field][key]), (where, field, key, ours[field][i, k],
                                                                      r[field][key])
                compared += 1
        for k in range(4):
            assert same_number(ours["contact_forces"][i, k], r["contact_forces"][k]), (where, "contact_forces", k)
            compared += 1
        for field in TEXT_FIELDS:
            assert ours[field][i] == r[field], (where, field, ours[field][i], r[field])
            compared += 1
        assert unprefixed(ours["message"][i]) == unprefixed(r["message"]), (where, ours["message"][i], r["message"])
        if r["status"] == 2:
            assert ours["message"][i].startswith(f"row {i}: "), ours["message"][i]
        compared += 1
        if poses:
            for field, keys in POSE_FIELDS.items():
                for k, key in enumerate(keys):
                    assert same_number(ours[field][i, k], line[field][key]), (where, field, key)
                    compared += 1
            tool = line["tool_pose"]["pose"]
            for k, v in enumerate([*(tool["position"][c] for c in XYZ), *(tool["orientation"][c] for c in XYZW)]):
                assert same_number(ours["tool_pose"][i, k], v), (where, "tool_pose", k, ours["tool_pose"][i, k], v)
                compared += 1
    return compared


def point(v) -> dict:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def grasp_lines(c1, n1, c2, n2, com, gravity, mass, friction, model: int) -> list[dict]:
    """The GraspCandidate lines of the rows of arrays (friction: (N,) or (N, 2))."""
    friction = np.asarray(friction)
    lines = []
    for i in range(len(mass)):
        f1, f2 = (friction[i, 0], friction[i, 1]) if friction.ndim == 2 else (friction[i], friction[i])
        lines.append({
            "id": f"row-{i}", "model": model,
            "contact_1": point(c1[i]), "contact_2": point(c2[i]),
            "normal_1": point(n1[i]), "normal_2": point(n2[i]),
            "friction_1": float(f1), "friction_2": float(f2),
            "center_of_mass": point(com[i]), "mass": float(mass[i]), "gravity": point(gravity[i]),
        })
    return lines
