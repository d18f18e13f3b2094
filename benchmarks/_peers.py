"""Peers that pin another Pinocchio: their own venvs, a JSON worker protocol, and the models they load.

PlaCo pins ``pin==3.8.0`` and roboplan its own ``pin``; installing either in
the main ``.venv`` would replace kinserve's Pinocchio. ``make bench`` creates
``bench-out/venvs/<peer>`` for each (see the Makefile); the benchmarks run the
peer in that venv as a subprocess (``benchmarks/worker_<peer>.py``) and talk
to it in JSON lines over stdin/stdout: one request ``{"cmd": ..., ...}`` per
line, one answer per line. Solve times are measured *inside* the worker around
the solver call, so the pipe costs nothing in the figures. A missing venv or a
worker that fails to start is reported and the peer skipped - never a crash.

Peers are given the same robot: :func:`arm_urdf` writes the Panda arm chain
``panda_link0 .. panda_link8`` (7 revolute joints, the flange) of the very
URDF kinserve loads, with the collision geometry a benchmark asks for (thin
cylinders along the skeleton segments, obstacle links fixed to the base), and
every benchmark checks the peer's FK against kinserve's before timing.
"""

from __future__ import annotations

import json
import os
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
VENVS = Path(os.environ.get("KINSERVE_BENCH_VENVS", ROOT / "bench-out" / "venvs"))
HERE = Path(__file__).resolve().parent


def peer_python(peer: str) -> Path | None:
    """The interpreter of ``bench-out/venvs/<peer>`` or None when that venv does not exist."""
    py = VENVS / peer / "bin" / "python"
    return py if py.exists() else None


class PeerError(RuntimeError):
    pass


class PeerWorker:
    """A peer solver in its own venv, driven over JSON lines (see the module docstring)."""

    def __init__(self, peer: str, timeout: float = 120.0, python: str | None = None):
        """``python``: the interpreter to run the worker with (a peer that works with kinserve's Pinocchio
        runs in the main venv's, apart all the same); by default ``bench-out/venvs/<peer>``'s."""
        py = python or peer_python(peer)
        if py is None:
            raise PeerError(f"no venv {VENVS / peer} (run `make bench` to create it)")
        script = HERE / f"worker_{peer}.py"
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        env.pop("PYTHONPATH", None)
        self.peer = peer
        self.proc = subprocess.Popen([str(py), str(script)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, env=env, bufsize=1)
        self.timeout = timeout
        hello = self.call({"cmd": "version"})
        self.version = hello.get("version", "?")

    def call(self, request: dict) -> dict:
        if self.proc.poll() is not None:
            raise PeerError(f"{self.peer} worker exited: {self.proc.stderr.read()[-2000:]}")
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise PeerError(f"{self.peer} worker died: {self.proc.stderr.read()[-2000:]}")
        answer = json.loads(line)
        if "error" in answer:
            raise PeerError(f"{self.peer} worker: {answer['error']}")
        return answer

    def try_call(self, request: dict) -> dict | None:
        """:meth:`call`, or None once the worker has failed (reported once; later calls return None at
        once)."""
        if getattr(self, "failed", None):
            return None
        try:
            return self.call(request)
        except (PeerError, OSError, json.JSONDecodeError) as exc:
            self.failed = str(exc)
            print(f"WARNING {self.peer} failed, its remaining solves count as failures: {exc}", flush=True)
            return None

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write(json.dumps({"cmd": "quit"}) + "\n")
                self.proc.stdin.flush()
                self.proc.wait(timeout=10)
            except Exception:  # noqa: BLE001 - the worker is ours; make sure it ends
                self.proc.kill()
                self.proc.wait()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def start_peer(peer: str, python: str | None = None) -> PeerWorker | None:
    """Start a worker (with ``python``, else in its own venv) or print why the peer is skipped (None)."""
    try:
        w = PeerWorker(peer, python=python)
    except (PeerError, OSError, json.JSONDecodeError) as exc:
        print(f"SKIP {peer}: {exc}".strip().splitlines()[0], flush=True)
        return None
    print(f"{peer} {w.version} running in {python or VENVS / peer}", flush=True)
    return w


def peer_solve(w: PeerWorker, solve, request: dict, budget: float) -> np.ndarray | None:
    """One ``solve`` request (``request``: its fields but ``cmd``) to worker ``w``, on behalf of the
    benchmark's solver function ``solve``: returns the peer's answer ``q`` (None when the call failed or it
    found none) and sets ``solve.inner_time`` / ``solve.inner_cpu`` to the worker's own measurement around its
    solver (``budget`` when the call failed), which :func:`_common.timed` reports instead of the pipe's."""
    a = w.try_call({"cmd": "solve", **request})
    solve.inner_time = budget if a is None else a["time"]
    solve.inner_cpu = budget if a is None else a.get("cpu", a["time"])
    return None if a is None or a.get("q") is None else np.asarray(a["q"])


def setup_or_skip(w: PeerWorker, request: dict, check=None) -> dict | None:
    """``w``'s answer to its ``setup`` ``request`` (then ``check(w)``, e.g. its FK against ours), or None
    after printing why the peer is skipped and closing its worker."""
    try:
        answer = w.call(request)
        if check is not None:
            check(w)
    except Exception as exc:  # noqa: BLE001 - any failure of a peer skips it, never the benchmark
        print(f"SKIP {w.peer}: setup failed: {exc}")
        w.close()
        return None
    return answer


# --------------------------------------------------------------------------- models for the peers
def _rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """URDF ``rpy`` of a rotation (``R = Rz(y) Ry(p) Rx(r)``), gimbal lock handled by Pinocchio."""
    import pinocchio as pin

    return tuple(float(v) for v in pin.rpy.matrixToRpy(np.asarray(R, dtype=float)))


def _rpy_z_to(v: np.ndarray) -> tuple[float, float, float]:
    """URDF ``rpy`` of a rotation taking the local z axis to the direction of ``v``."""
    z = v / np.linalg.norm(v)
    x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return _rpy_of(np.column_stack([x, np.cross(z, x), z]))


def _vec(text: str | None) -> np.ndarray:
    return np.array([float(v) for v in (text or "0 0 0").split()])


def segment_cylinders(urdf_text: str, base: str, tip: str) -> list[tuple[str, np.ndarray]]:
    """``(link, end)``: for each moving link of the chain, the next joint's origin in that link's frame.

    The skeleton segment of a link runs from its own origin (its joint's axis
    point) to ``end``; zero-length segments (Panda joint 2 sits on joint 1's
    origin) are left out.
    """
    root = ET.fromstring(urdf_text)
    by_parent = {j.find("parent").get("link"): j for j in root.findall("joint")}
    out, link = [], base
    while link != tip:
        j = by_parent[link]
        child = j.find("child").get("link")
        if link != base:
            end = _vec(j.find("origin").get("xyz") if j.find("origin") is not None else None)
            if np.linalg.norm(end) > 1e-9:
                out.append((link, end))
        link = child
    return out


def arm_urdf(urdf_text: str, base: str = "panda_link0", tip: str = "panda_link8", *,
             segment_radius: float | None = None, obstacles=(),
             keep_collision: bool = False) -> tuple[str, list]:
    """The chain ``base .. tip`` of ``urdf_text`` as a URDF of its own; returns ``(text, collision_pairs)``.

    Visuals are dropped; ``keep_collision`` keeps the URDF's collision meshes,
    ``segment_radius`` replaces them by cylinders of that radius along the
    skeleton segments (:func:`segment_cylinders`). ``obstacles`` (plain dicts
    ``{"kind": "sphere"|"box", ...}``) become links ``obstacle_k`` fixed to
    ``base``. ``collision_pairs`` lists ``[link, obstacle_k]`` for every
    link with collision geometry and every obstacle.
    """
    src = ET.fromstring(urdf_text)
    links = {el.get("name"): el for el in src.findall("link")}
    by_parent = {j.find("parent").get("link"): j for j in src.findall("joint")}
    robot = ET.Element("robot", name="arm")
    chain_links, joints, link = [base], [], base
    while link != tip:
        j = by_parent[link]
        joints.append(j)
        link = j.find("child").get("link")
        chain_links.append(link)
    segs = dict(segment_cylinders(urdf_text, base, tip)) if segment_radius else {}
    colliding = []
    for name in chain_links:
        el = ET.SubElement(robot, "link", name=name)
        inertial = links[name].find("inertial")
        if inertial is not None:
            el.append(inertial)
        if keep_collision:
            for c in links[name].findall("collision"):
                el.append(c)
                if name not in colliding:
                    colliding.append(name)
        if name in segs:
            end = segs[name]
            r, p, y = _rpy_z_to(end)
            c = ET.SubElement(el, "collision")
            mid = 0.5 * end
            ET.SubElement(c, "origin", xyz=" ".join(f"{v:.9g}" for v in mid),
                          rpy=f"{r:.12g} {p:.12g} {y:.12g}")
            g = ET.SubElement(c, "geometry")
            ET.SubElement(g, "cylinder", radius=f"{segment_radius:g}", length=f"{np.linalg.norm(end):.9g}")
            colliding.append(name)
    for j in joints:
        robot.append(j)
    pairs = []
    for k, ob in enumerate(obstacles):
        name = f"obstacle_{k}"
        el = ET.SubElement(robot, "link", name=name)
        inert = ET.SubElement(el, "inertial")
        ET.SubElement(inert, "mass", value="1")
        ET.SubElement(inert, "inertia", ixx="1e-3", iyy="1e-3", izz="1e-3", ixy="0", ixz="0", iyz="0")
        c = ET.SubElement(el, "collision")
        g = ET.SubElement(c, "geometry")
        joint = ET.SubElement(robot, "joint", name=f"{name}_joint", type="fixed")
        ET.SubElement(joint, "parent", link=base)
        ET.SubElement(joint, "child", link=name)
        if ob["kind"] == "sphere":
            ET.SubElement(g, "sphere", radius=f"{ob['radius']:.12g}")
            ET.SubElement(joint, "origin", xyz=" ".join(f"{v:.12g}" for v in ob["center"]), rpy="0 0 0")
        else:
            T = np.asarray(ob["pose"], dtype=float)
            ET.SubElement(g, "box", size=" ".join(f"{v:.12g}" for v in ob["size"]))
            rr = _rpy_of(T[:3, :3])
            ET.SubElement(joint, "origin", xyz=" ".join(f"{v:.12g}" for v in T[:3, 3]),
                          rpy=" ".join(f"{v:.15g}" for v in rr))
        pairs += [[lk, name] for lk in colliding]
    return ET.tostring(robot, encoding="unicode"), pairs
