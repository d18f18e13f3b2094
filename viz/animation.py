"""``Animation``: keyframed motion of scene nodes, played in the browser.

meshcat animates a node by a three.js ``AnimationClip`` with a ``.position``
and a ``.quaternion`` track; key times are *frame numbers* and the clip's
``fps`` turns them into seconds (frame ``k`` plays at ``t = k / fps``).
Between keys three.js interpolates linearly (slerp for the rotation), so one
key per trajectory sample reproduces the sampled motion exactly at the samples.

This module turns plain data into such keys:

* :meth:`Animation.robot` - a joint trajectory ``Q`` (``(N, nq)``): every link
  geometry of a :class:`viz.scene.SceneRobot` gets the key ``oMg(q_i)``
  (Pinocchio's geometry placement, the same pose :meth:`Scene.add_robot`
  draws statically);
* :meth:`Animation.poses` - any node along a sequence of 4x4 poses;
* :meth:`Animation.planar` - a base moving on a 2-D map, ``(x, y, theta)``;
* :meth:`Animation.attach` - an object carried by the robot's tool between two
  trajectory steps (grasp -> release): rigidly attached with the offset it had
  at the grasp step, ``W_obj(k) = W_tool(k) W_tool(grasp)^-1 W_obj(grasp)``, then
  left where it was released.

Poses are relative to the node's parent in the scene tree (for a robot link
that is the robot's root node, whose transform is the base pose); attach and
:meth:`world_pose` account for that.
"""

from __future__ import annotations

import meshcat
import meshcat.animation as ma
import meshcat.commands
import meshcat.path
import numpy as np
import pinocchio as pin

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_count, as_flag, as_matrix, as_pose, as_positive

from .scene import Scene

#: Largest accepted frame rate (frames per second) of an animation.
MAX_FPS = 240.0
#: Most frames one animation may hold; frame indices are below it.
MAX_FRAMES = 10**5
#: Most times an applied animation may repeat.
MAX_REPETITIONS = 10**6


def _quat_xyzw(R: np.ndarray) -> np.ndarray:
    return np.array(pin.Quaternion(np.asarray(R, dtype=float)).coeffs())


def _pose_from(p, q_xyzw) -> np.ndarray:
    x, y, z, w = q_xyzw
    qt = pin.Quaternion(w, x, y, z)
    qt.normalize()
    T = np.eye(4)
    T[:3, :3] = qt.toRotationMatrix()
    T[:3, 3] = p
    return T


class Animation:
    """Keyframes for the nodes of one :class:`Scene` (see the module docstring).

    Parameters
    ----------
    scene:
        The scene whose nodes are animated (nodes must exist when keyed).
    fps:
        Frames per second of playback; frame ``k`` is shown at ``k / fps`` s. Refused outside
        (0, :data:`MAX_FPS` = 240]; frames are below :data:`MAX_FRAMES` (10**5) and an empty
        trajectory is refused.
    """

    def __init__(self, scene: Scene, fps: float = 30.0):
        if not isinstance(scene, Scene):
            raise InputError(f"Animation needs a viz.Scene, got {type(scene).__name__}")
        fps = as_positive(fps, "fps (frames per second)", maximum=MAX_FPS)
        self.scene = scene
        self.fps = fps
        self._keys: dict[str, dict[int, np.ndarray]] = {}
        self._robot_steps: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    # ------------------------------------------------------------ keys
    @property
    def n_frames(self) -> int:
        """Number of frames (last keyed frame + 1; 0 when empty)."""
        last = [max(k) for k in self._keys.values() if k]
        return max(last) + 1 if last else 0

    @property
    def duration(self) -> float:
        """Playback length in seconds, ``(n_frames - 1) / fps``."""
        return max(self.n_frames - 1, 0) / self.fps

    @property
    def nodes(self) -> list[str]:
        """Absolute paths of the animated nodes."""
        return list(self._keys)

    def _frames(self, n: int, start: int, step: int) -> np.ndarray:
        """Frames ``start + i*step`` of ``n`` samples; refused: ``n == 0``, ``start < 0``, ``step < 1``, or a
        last frame beyond :data:`MAX_FRAMES` - 1."""
        start = as_count(start, "start", minimum=0, maximum=MAX_FRAMES - 1)
        step = as_count(step, "step", minimum=1, maximum=MAX_FRAMES)
        if n == 0:
            raise InputError("need at least one sample to key (got an empty trajectory, 0 rows)")
        last = start + step * (n - 1)
        if last >= MAX_FRAMES:
            raise InputError(f"an animation holds at most {MAX_FRAMES:,} frames; {n} samples from frame "
                             f"{start} every {step} end at frame {last}")
        return start + step * np.arange(n)

    def _node(self, name: str) -> str:
        path = Scene.path(name)
        if path not in self.scene:
            raise InputError(f"cannot animate {path!r}: no such node in the scene (draw it first)")
        return path

    def key(self, name: str, frame: int, pose) -> None:
        """Key one pose (4x4, relative to the node's parent) at ``frame``."""
        frame = as_count(frame, "frame", minimum=0, maximum=MAX_FRAMES - 1)
        self._keys.setdefault(self._node(name), {})[frame] = as_pose(pose, "pose").copy()

    def poses(self, name: str, poses, start: int = 0, step: int = 1) -> None:
        """Key node ``name`` at the poses ``(N, 4, 4)``: pose ``i`` at frame ``start + i*step``."""
        P = as_matrix(poses, (-1, 4, 4), "poses")
        path = self._node(name)
        track = self._keys.setdefault(path, {})
        for f, T in zip(self._frames(len(P), start, step), P):
            track[int(f)] = as_pose(T, "poses[i]").copy()

    def planar(self, name: str, xytheta, start: int = 0, step: int = 1, z: float = 0.0) -> None:
        """Key a node moving in a plane: rows ``(x, y, theta)`` -> ``Trans(x, y, z) Rz(theta)``.

        Units are those of the node's parent (map units under a map node).
        """
        X = as_matrix(xytheta, (-1, 3), "xytheta")
        P = np.tile(np.eye(4), (len(X), 1, 1))
        c, s = np.cos(X[:, 2]), np.sin(X[:, 2])
        P[:, 0, 0], P[:, 0, 1], P[:, 1, 0], P[:, 1, 1] = c, -s, s, c
        P[:, 0, 3], P[:, 1, 3], P[:, 2, 3] = X[:, 0], X[:, 1], float(z)
        self.poses(name, P, start, step)

    def robot(self, name: str, Q, start: int = 0, step: int = 1) -> np.ndarray:
        """Key every link of scene robot ``name`` along the joint trajectory ``Q`` (``(N, nq)``).

        Sample ``i`` is shown at frame ``start + i*step``; returns those frames.
        """
        handle = self.scene.robots.get(name)
        if handle is None:
            raise InputError(f"no robot {name!r} in the scene; robots: {sorted(self.scene.robots)}")
        Q = as_matrix(Q, (-1, handle.robot.nq), "Q")
        frames = self._frames(len(Q), start, step)
        for f, q in zip(frames, Q):
            for path, T in handle.geometry_poses(q, world=False).items():
                self._keys.setdefault(path, {})[int(f)] = T
        self._robot_steps[name] = (frames, Q.copy())
        # the scene's automatic camera frames the whole motion: geometry boxes at (up to) 40 of its samples
        picks = np.unique(np.linspace(0, len(Q) - 1, min(len(Q), 40)).round().astype(int))
        self.scene._note_points(f"{name}/motion", np.vstack([handle.geometry_corners(Q[i]) for i in picks]))
        return frames

    # ------------------------------------------------------------ queries
    def local_pose(self, name: str, frame: int) -> np.ndarray:
        """Pose of ``name`` relative to its parent at ``frame``: its last key at or before
        ``frame`` (the first key before the first one), or its static scene transform."""
        path = Scene.path(name)
        track = self._keys.get(path)
        if not track:
            return self.scene.transform(path)
        frames = sorted(track)
        earlier = [f for f in frames if f <= frame]
        return track[earlier[-1] if earlier else frames[0]].copy()

    def world_pose(self, name: str, frame: int) -> np.ndarray:
        """World pose of ``name`` at ``frame``: the product of :meth:`local_pose` along its path.

        Static transforms keep their scale (a map node scales its children to metres).
        """
        parts = [p for p in Scene.path(name).split("/") if p]
        T = np.eye(4)
        for i in range(1, len(parts) + 1):
            T = T @ self.local_pose("/" + "/".join(parts[:i]), frame)
        return T

    def tool_poses(self, robot: str, frame: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(frames, poses)``: world poses of the robot's tool frame at its keyed trajectory samples."""
        if robot not in self._robot_steps:
            raise InputError(f"robot {robot!r} has no keyed trajectory; call Animation.robot({robot!r}, "
                             "Q) first")
        handle = self.scene.robots[robot]
        frames, Q = self._robot_steps[robot]
        poses = np.array([self.world_pose(handle.root, int(f)) @ handle.robot.fk(q, frame)
                          for f, q in zip(frames, Q)])
        return frames, poses

    # ------------------------------------------------------------ grasping
    def attach(self, name: str, robot: str, grasp: int, release: int | None = None,
               frame: str | None = None) -> np.ndarray:
        """Carry node ``name`` with the robot's tool from trajectory step ``grasp`` to ``release``.

        Steps index the ``Q`` given to :meth:`robot` (``release=None``: until
        the end). Before ``grasp`` the object stays at its pose at ``grasp``'s
        frame; from ``grasp`` to ``release`` it follows the tool rigidly,
        ``W_obj(k) = W_tool(k) W_tool(grasp)^-1 W_obj(grasp)``; afterwards it
        stays where it was released. Returns the world poses ``(N, 4, 4)`` of
        the object at every step.
        """
        frames, tool = self.tool_poses(robot, frame)
        n = len(frames)
        release = n - 1 if release is None else int(release)
        grasp = int(grasp)
        if not (0 <= grasp <= release < n):
            raise InputError(f"need 0 <= grasp <= release < {n} (trajectory steps), got grasp={grasp}, "
                             f"release={release}")
        path = self._node(name)
        parent = "/".join(path.split("/")[:-1]) or "/"
        W0 = self.world_pose(path, int(frames[grasp]))
        offset = np.linalg.solve(tool[grasp], W0)  # W_tool(grasp)^-1 W_obj(grasp)
        world = np.empty((n, 4, 4))
        for i in range(n):
            k = min(max(i, grasp), release)
            world[i] = W0 if i < grasp else tool[k] @ offset
        track = self._keys.setdefault(path, {})
        for f, W in zip(frames, world):
            P = self.world_pose(parent, int(f)) if parent not in ("/", "") else np.eye(4)
            track[int(f)] = np.linalg.solve(P, W)
        return world

    # ------------------------------------------------------------ meshcat
    def to_meshcat(self) -> ma.Animation:
        """The ``meshcat.animation.Animation``: one clip per node, a position and a
        quaternion key per keyed frame, each track held to the last frame.

        Quaternion signs are made continuous (``q`` and ``-q`` are the same
        rotation; slerp between keys must not take the long way round).
        """
        anim = ma.Animation(default_framerate=self.fps)
        last = self.n_frames - 1
        for path, track in self._keys.items():
            if not track:
                continue
            clip = ma.AnimationClip(fps=self.fps, name="default")
            frames = sorted(track)
            if frames[-1] < last:
                track = dict(track)
                track[last] = track[frames[-1]]
                frames.append(last)
            prev = None
            for f in frames:
                T = track[f]
                q = _quat_xyzw(T[:3, :3])
                if prev is not None and float(np.dot(q, prev)) < 0:
                    q = -q
                prev = q
                clip.set_property(f, "position", "vector3", [float(v) for v in T[:3, 3]])
                clip.set_property(f, "quaternion", "quaternion", [float(v) for v in q])
            anim.clips[meshcat.path.Path(tuple(p for p in path.split("/") if p))] = clip
        return anim

    def lower(self) -> list:
        """The animation as meshcat's ``set_animation`` payload."""
        return self.to_meshcat().lower()

    def apply(self, play: bool = True, repetitions: int = 1) -> None:
        """Record this animation in its scene (a scene holds one animation; the last applied wins).

        ``play``: start it when the page opens (True or False); ``repetitions``: how many times it runs,
        an integer from 1 to :data:`MAX_REPETITIONS`.
        """
        play = as_flag(play, "play")
        repetitions = as_count(repetitions, "repetitions", minimum=1, maximum=MAX_REPETITIONS)
        if self.n_frames == 0:
            raise InputError("the animation has no keyframes")
        self.scene.send(meshcat.commands.SetAnimation(self.to_meshcat(), play=play, repetitions=repetitions))


def pose_at(animation_command: dict, path: str, frame: int) -> np.ndarray:
    """Read back the pose keyed for ``path`` at ``frame`` from a lowered ``set_animation`` command."""
    for entry in animation_command["animations"]:
        if entry["path"] == path:
            tracks = {t["name"]: {k["time"]: k["value"] for k in t["keys"]} for t in entry["clip"]["tracks"]}
            return _pose_from(tracks[".position"][frame], tracks[".quaternion"][frame])
    raise InputError(f"no animation track for {path!r}")
