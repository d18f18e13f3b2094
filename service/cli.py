"""The ``kinserve`` command line.

Each sub-command parses its arguments, calls the library and prints the
answer (plain text, or JSON with ``--json``). ``kinserve --version`` prints
``kinserve <version>``.

Errors never end in a traceback: library errors
(:class:`kinserve.kinematics.errors.KinserveError`) and operating-system errors
(a folder that cannot be written, a port that cannot be bound: ``OSError``)
become one ``error: ...`` line on stderr and exit status 2, as argparse does
for malformed arguments. Anything else is a bug: one ``error: internal ...``
line and exit status 70 (``KINSERVE_DEBUG=1`` re-raises it with its traceback).
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

from kinserve.kinematics.errors import KinserveError, ShapeError

EXIT_USAGE = 2
EXIT_INTERNAL = 70  # sysexits.h EX_SOFTWARE: an unexpected exception, i.e. a bug in kinserve


# ----------------------------------------------------------------- helpers
def parse_vector(values: list[str] | None, name: str = "--q") -> np.ndarray | None:
    """Numbers from ``--q 0 0.1 0.2`` or ``--q 0,0.1,0.2`` (or a JSON list)."""
    if not values:
        return None
    text = " ".join(values).strip()
    if text.startswith("["):
        try:
            return np.asarray(json.loads(text), dtype=float)
        except (ValueError, TypeError):
            raise ShapeError(f"{name}: expected a JSON list of numbers, got {text!r}") from None
    parts = [p for p in text.replace(",", " ").split() if p]
    try:
        return np.array([float(p) for p in parts])
    except ValueError:
        raise ShapeError(f"{name}: expected numbers separated by spaces or commas, got {text!r}") from None


def parse_params(items: list[str] | None) -> dict:
    """``--param l1=1.2 --param name=x`` into ``{"l1": 1.2, "name": "x"}`` (numbers parsed)."""
    params = {}
    for item in items or []:
        if "=" not in item:
            raise ShapeError(f"--param expects KEY=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        try:
            params[key.strip()] = float(value)
        except ValueError:
            params[key.strip()] = value
    return params


def load_robot(args, *, geometry: bool | None = None, task_axes=None):
    """The robot named by the arguments of :func:`add_robot_args` (``geometry`` defaults to
    ``args.geometry``)."""
    from kinserve import robots

    return robots.load(
        args.robot,
        params=parse_params(getattr(args, "param", None)),
        geometry=getattr(args, "geometry", False) if geometry is None else geometry,
        package_dirs=getattr(args, "package_dir", None) or None,
        srdf=getattr(args, "srdf", None),
        allow_outside=getattr(args, "allow_outside", False),
        task_axes=task_axes,
    )


def robot_frame(robot, args) -> str:
    """``--frame`` checked against ``robot`` (an unknown or empty name is a :class:`FrameError` naming it and
    suggesting close names), or the robot's tool frame when the option is absent."""
    frame = getattr(args, "frame", None)
    if frame is None:
        return robot.tip
    robot.frame_id(frame)
    return frame


def robot_q(robot, args) -> np.ndarray:
    """``--q`` checked against ``robot`` (length, limits), or the robot's neutral configuration.

    ``--frame``, when the sub-command has it, is checked here too (:func:`robot_frame`), so every
    sub-command refuses an unknown or empty frame name even when it does not use the frame.
    """
    robot_frame(robot, args)
    q = parse_vector(args.q)
    return robot.neutral() if q is None else robot.check_q(q)


def fmt_matrix(M: np.ndarray, digits: int = 6) -> str:
    """``M`` as text, one indented row per line, ``digits`` decimals."""
    return "\n".join("  " + " ".join(f"{v: .{digits}f}" for v in row) for row in np.atleast_2d(M))


def emit(args, payload: dict, text: str) -> None:
    """Print ``payload`` as JSON with ``--json``, else ``text``."""
    print(json.dumps(payload, indent=2) if getattr(args, "json", False) else text)


def add_robot_args(p: argparse.ArgumentParser, q: bool = True) -> None:
    """Add the robot arguments shared by the sub-commands (and ``--q`` when ``q``) to ``p``."""
    p.add_argument("robot", help="built-in robot name (see `kinserve models`), or a .urdf/.xacro path")
    p.add_argument("--param", action="append", metavar="KEY=VALUE",
                   help="model parameter / xacro arg, repeatable (default: the model's own values)")
    p.add_argument("--package-dir", action="append", metavar="DIR",
                   help="folder resolving package://PKG/... and $(find PKG): a package, a folder of "
                        "packages or a workspace (repeatable; searched before the model's own folders, "
                        "$ROS_PACKAGE_PATH and $AMENT_PREFIX_PATH; default: none)")
    p.add_argument("--srdf", metavar="FILE",
                   help="SRDF with named states and groups (default: the one beside the model)")
    p.add_argument("--allow-outside", action="store_true",
                   help="let the model read mesh and xacro-included files outside its own folder and the "
                        "package folders")
    if q:
        p.add_argument("--q", nargs="+", metavar="Q",
                       help="joint values (rad / m), space or comma separated (default: the neutral "
                            "configuration)")
        p.add_argument("--frame", help="frame name (default: the robot's tool frame)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")


# ---------------------------------------------------------------- commands
def cmd_models(args) -> int:
    """``kinserve models``: the built-in robot names and descriptions; returns 0."""
    from kinserve import robots

    models = robots.available()
    width = max(map(len, models))
    emit(args, models, "\n".join(f"{name:<{width}}  {desc}" for name, desc in models.items()))
    return 0


def cmd_fk(args) -> int:
    """``kinserve fk``: the 4x4 pose of a frame at ``--q``; returns 0."""
    robot = load_robot(args)
    q = robot_q(robot, args)
    frame = robot_frame(robot, args)
    T = robot.fk(q, frame)
    text = f"{robot.name}  frame {frame}  q = {np.array2string(q, precision=4)}\npose (4x4):\n{fmt_matrix(T)}"
    emit(args, {"robot": robot.name, "frame": frame, "q": q.tolist(), "pose": T.tolist()}, text)
    return 0


def task_axes_origin(robot, given) -> str:
    """Why ``robot.task_axes`` are what they are, in words (for the CLI)."""
    from kinserve.kinematics.task_axes import detect_task_axes

    if given:
        return "given with --axes"
    detected = detect_task_axes(robot.model)
    if detected.axes == robot.task_axes:
        return f"detected: {detected.reason}"
    return "set by the built-in robot's entry"


def cmd_jacobian(args) -> int:
    """``kinserve jacobian``: the frame Jacobian at ``--q``, singular values, manipulability; returns 0."""
    robot = load_robot(args, task_axes=args.axes)
    q = robot_q(robot, args)
    frame = robot_frame(robot, args)
    J = robot.jacobian(q, frame, reference=args.reference)
    sv = robot.singular_values(q, frame)
    manip = float(np.prod(sv))
    singular = robot.is_singular(q, frame=frame)
    origin = task_axes_origin(robot, args.axes)
    text = (
        f"{robot.name}  frame {frame}  reference {args.reference}  q = {np.array2string(q, precision=4)}\n"
        f"Jacobian (6x{robot.nq}, rows vx vy vz wx wy wz):\n{fmt_matrix(J)}\n"
        f"task axes {', '.join(robot.task_axes)} ({origin}):\n"
        f"  singular values {np.array2string(sv, precision=5)}, "
        f"manipulability {manip:.6g}{'  SINGULAR' if singular else ''}"
    )
    payload = {
        "robot": robot.name, "frame": frame, "reference": args.reference, "q": q.tolist(),
        "jacobian": J.tolist(), "task_axes": list(robot.task_axes), "task_axes_origin": origin,
        "singular_values": sv.tolist(), "manipulability": manip, "singular": singular,
    }
    emit(args, payload, text)
    return 0


COMMANDS: dict[str, tuple] = {}


class OneLineParser(argparse.ArgumentParser):
    """argparse with its usage errors as one ``error: ...`` line (exit 2) instead of usage + message, and
    every option's default in its help line (:class:`~kinserve.service.cli_help.DefaultsHelpFormatter`).

    Sub-command parsers inherit the class (``add_subparsers`` uses the parent's type).
    """

    def __init__(self, *args, **kwargs) -> None:
        from .cli_help import DefaultsHelpFormatter

        kwargs.setdefault("formatter_class", DefaultsHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # type: ignore[override]
        """Exit with status 2 and one ``error: ...`` line on stderr."""
        self.exit(EXIT_USAGE, f"error: {self.prog}: {message} (see `{self.prog} --help`)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``kinserve`` argument parser with every sub-command registered."""
    from kinserve import __version__

    parser = OneLineParser(prog="kinserve",
                           description="Pinocchio-based kinematics: FK, Jacobians, IK, plans.")
    parser.add_argument("--version", action="version", version=f"kinserve {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("models", help="list the built-in robots")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=cmd_models)

    p = sub.add_parser("fk", help="forward kinematics: pose of a frame")
    add_robot_args(p)
    p.set_defaults(func=cmd_fk)

    p = sub.add_parser("jacobian", help="geometric Jacobian and singularity measures")
    add_robot_args(p)
    p.add_argument("--reference", default="world", choices=["world", "local", "spatial"],
                   help="world: the frame origin's velocity, world axes (geometric Jacobian); local: the "
                        "same in the frame's own axes; spatial: Pinocchio's WORLD (the body point at the "
                        "world origin)")
    p.add_argument("--axes", metavar="A,B,...",
                   help="task rows for the singularity measures, e.g. x,y,z or x,y,yaw (default: "
                        "the robot's task axes)")
    p.set_defaults(func=cmd_jacobian)

    import importlib

    for module in _EXTRA_COMMANDS:
        importlib.import_module(module).register(sub)
    return parser


#: Modules defining further sub-commands, each with ``register(subparsers)``.
_EXTRA_COMMANDS = ("kinserve.service.cli_ik", "kinserve.service.cli_demo", "kinserve.service.cli_view",
                   "kinserve.service.cli_serve", "kinserve.service.cli_reach", "kinserve.service.cli_frames",
                   "kinserve.service.cli_collide", "kinserve.service.cli_plan")


def describe_os_error(exc: OSError) -> str:
    """One line for an ``OSError``: ``"/proc/nope/planar4r: No such file or directory"`` style."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    if exc.filename is not None:
        return f"{exc.filename}: {reason}"
    return reason


def main(argv: list[str] | None = None) -> int:
    """Run the ``kinserve`` command line on ``argv``; returns the exit status (2 for invalid input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KinserveError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # e.g. `kinserve demo all | head`: the reader left, nothing more to say
        sys.stderr.close()
        return 0
    except OSError as exc:
        print(f"error: {describe_os_error(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # a bug: still one line, unless the user asks for the traceback
        if os.environ.get("KINSERVE_DEBUG"):
            raise
        print(f"error: internal {type(exc).__name__}: {exc} (KINSERVE_DEBUG=1 shows the traceback)",
              file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
