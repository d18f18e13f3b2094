"""``kinserve frames ROBOT [--json]``: what a robot is made of.

Prints the tool frame, the joints (type, limits in rad or m), every frame
(type and the joint that moves it), the task axes singularity measures use
(and why), and the SRDF's named states and groups. Error messages about an
unknown frame point here.
"""

from __future__ import annotations

import argparse

import pinocchio as pin


def joint_kind(model: pin.Model, joint_id: int) -> str:
    """``"prismatic"`` or ``"revolute"`` for a 1-DOF Pinocchio joint."""
    short = model.joints[joint_id].shortname()
    return "prismatic" if "Prismatic" in short or short.startswith("JointModelP") else "revolute"


def describe(robot) -> dict:
    """Plain-data description of a robot: tool frame, joints, frames, task axes, SRDF states and groups."""
    from kinserve.service.cli import task_axes_origin

    model = robot.model
    joints = []
    for i, name in enumerate(robot.joint_names):
        kind = joint_kind(model, i + 1)
        joints.append({"name": name, "type": kind, "unit": "m" if kind == "prismatic" else "rad",
                       "lower": float(robot.lower[i]), "upper": float(robot.upper[i])})
    frames = []
    for name in robot.frame_names:
        f = model.frames[robot.frame_id(name)]
        frames.append({"name": name, "type": str(f.type).rsplit(".", 1)[-1],
                       "moved_by": model.names[f.parentJoint]})
    return {
        "robot": robot.name, "nq": robot.nq, "tool_frame": robot.tip, "joints": joints, "frames": frames,
        "task_axes": list(robot.task_axes), "task_axes_origin": task_axes_origin(robot, None),
        "named_states": {k: v.tolist() for k, v in robot.named_states.items()},
        "groups": {k: list(v) for k, v in robot.groups.items()}, "srdf": robot.srdf_path,
    }


def as_text(d: dict) -> str:
    """The text form of :func:`describe`'s dict: joints with limits, then frames."""
    lines = [f"{d['robot']}: {d['nq']} joints, tool frame {d['tool_frame']}", "", "joints (limits):"]
    width = max(len(j["name"]) for j in d["joints"])
    for j in d["joints"]:
        lines.append(f"  {j['name']:<{width}}  {j['type']:<9}  "
                     f"[{j['lower']: .4f}, {j['upper']: .4f}] {j['unit']}")
    lines += ["", f"frames ({len(d['frames'])}; TYPE, moved by joint):"]
    width = max(len(f["name"]) for f in d["frames"])
    for f in d["frames"]:
        tool = "  <- tool frame" if f["name"] == d["tool_frame"] else ""
        lines.append(f"  {f['name']:<{width}}  {f['type']:<11}  {f['moved_by']}{tool}")
    lines += ["", f"task axes: {' '.join(d['task_axes'])} ({d['task_axes_origin']})"]
    if d["named_states"] or d["groups"]:
        lines += ["", f"SRDF {d['srdf']}:"]
        for name, joints in d["groups"].items():
            lines.append(f"  group {name}: {' '.join(joints) or '(no movable joint)'}")
        for name, q in d["named_states"].items():
            lines.append(f"  state {name}: {' '.join(f'{v:.4f}' for v in q)}")
    return "\n".join(lines)


def cmd_frames(args) -> int:
    """``kinserve frames``: the robot's joints, limits and frames; returns 0."""
    from kinserve.service.cli import emit, load_robot

    description = describe(load_robot(args))
    emit(args, description, as_text(description))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``frames`` sub-command to ``sub``."""
    from kinserve.service.cli import add_robot_args

    p = sub.add_parser("frames", help="list a robot's frames, joints and limits, tool frame and task axes")
    add_robot_args(p, q=False)
    p.set_defaults(func=cmd_frames)
