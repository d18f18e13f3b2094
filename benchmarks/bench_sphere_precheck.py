"""The collision scene's checks with and without the sphere pre-check (issue 11): CPU time per call and rates.

Panda with its SRDF, the table and wall of ``bench_collision.py``. Figures (CPU time,
``time.process_time``, best of ``--rounds`` rounds over the same configurations):

* ``scene.in_collision(q)`` on configurations the pre-check certifies, on ones it does not, and on
  uniform random configurations;
* ``scene.first_collision(path)`` on the paths the collision-aware IK checks: the answer then the
  iterates of an unconstrained LM run, last first (``ik.collision.solve._path_is_free``'s order), for
  flange targets of collision-free random configurations and random starts (``--paths`` of them; the
  median path length is reported);
* the certification rate (share of the configurations coal finds free that the pre-check certifies) of
  random configurations and of the path configurations, in the open scene and with a 10 cm cube centred
  on the elbow (origin of ``panda_joint4``) of each path's answer.

With ``--ik N``: collision-aware ``ik.solve`` (flange targets of ``N`` collision-free configurations,
random starts; the open scene, and a 10 cm cube on the elbow of each target's unconstrained answer), per
target the best CPU time of 3 solves with the pre-check and 3 without, alternating; the medians, their
ratios to the unconstrained solve and the median per-target difference. ``--fresh`` empties the scene
caches before every cube solve (a solve in a scene the process has not seen).

Every timing is taken twice in the same process on the same inputs, alternating: with the pre-check
(``..._us``) and with it switched off on the scenes (``..._coal_us``: coal alone, the code before the
pre-check). Runs on a kinserve without the pre-check too (then only the coal figures):
``python benchmarks/bench_sphere_precheck.py --out bench-out/x.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from kinserve import ik, robots
from kinserve.ik.state import _NO_REQUEST as NO_REQUEST
from kinserve.kinematics.collision_model import _NO_SCENE as NO_SCENE

FRAME = "panda_link8"


def _pose(xyz) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def scene_obstacles() -> list:
    return [ik.Box(_pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.1)),
            ik.Box(_pose((0.0, -0.6, 0.5)), (1.5, 0.05, 1.0))]


def per_call_us(fn, items, rounds: int) -> float:
    """Best over ``rounds`` of the CPU time per call of ``fn(item)`` over ``items`` (us)."""
    best = float("inf")
    for _ in range(rounds):
        t0 = time.process_time()
        for x in items:
            fn(x)
        best = min(best, (time.process_time() - t0) / max(len(items), 1))
    return best * 1e6


def switch(scenes, on: bool) -> None:
    """The pre-check on (the scene's own, built once) or off (coal alone) on ``scenes``."""
    for s in scenes:
        if hasattr(s, "precheck"):
            s.precheck()
            switch_object(s, on)


def both(out: dict, key: str, scenes, fn, items, rounds: int) -> None:
    """``out[key + "_us"]`` with the pre-check, ``out[key + "_coal_us"]`` without, alternating rounds."""
    on = off = float("inf")
    for _ in range(rounds):
        switch(scenes, True)
        on = min(on, per_call_us(fn, items, 1))
        switch(scenes, False)
        off = min(off, per_call_us(fn, items, 1))
    switch(scenes, True)
    if hasattr(scenes[0], "precheck"):
        out[key + "_us"] = on
    out[key + "_coal_us"] = off


def certified(scene, qs) -> np.ndarray | None:
    """Per configuration, True when the pre-check certifies it (None without a pre-check)."""
    pre = getattr(scene, "precheck", None)
    if pre is None or pre() is None:
        return None
    from kinserve.kinematics.scene_precheck import certify

    return certify(pre(), np.asarray(qs))


def rate(scene, qs, truth) -> float | None:
    cert = certified(scene, qs)
    if cert is None:
        return None
    assert not np.any(cert & truth), "a configuration in collision was certified"
    return float(cert[~truth].mean()) if (~truth).any() else float("nan")


def coal_truth(scene, robot, qs) -> np.ndarray:
    gm = scene.geometry
    gd, data = pin.GeometryData(gm), robot.model.createData()
    return np.array([bool(pin.computeCollisions(robot.model, data, gm, gd, q, True)) for q in qs])


def forget_bound_scenes(robot) -> None:
    """Drop this thread's collision constraints bound by obstacle set (the IK state's ``BoundConstraints``),
    keeping the ones bound by layout: the next solve with the cube binds its scene anew, by moving the
    layout's template, as a solve in a new scene does."""
    state = robot.extensions.ik
    store = None if state is None else getattr(state.threads, "bound", None)
    if store is not None:
        store.by_scene.clear()
        store.last = (NO_REQUEST, None)


def ik_comparison(robot, obstacles, n: int, fresh: bool, seed: int) -> dict:
    """Per-target best-of-3 CPU times (us) of collision-aware solves with and without the pre-check (module
    docstring, ``--ik``); the pre-check objects once built are kept and put back when switched on."""
    cm = robot.collision
    scene = robot.collision_scene(obstacles)
    rng = np.random.default_rng(seed)
    data = robot.model.createData()
    elbow = robot.model.getJointId("panda_joint4")
    cases = []
    while len(cases) < n:
        q = robot.random_q(rng)
        if scene.in_collision(q):
            continue
        T, start = robot.fk(q, FRAME), robot.random_q(rng)
        pin.forwardKinematics(robot.model, data, ik.solve(robot, T, start, frame=FRAME, seed=len(cases)).q)
        cube = ik.Box(_pose(data.oMi[elbow].translation), (0.1, 0.1, 0.1))
        if robot.collision_scene([*obstacles, cube]).in_collision(q):
            continue  # the target must stay feasible
        cases.append((T, start, cube))

    def objects():
        last = cm._last_scene
        return [*cm._layouts.values(), *(() if last is NO_SCENE else (last,))]

    def put(on: bool) -> None:
        for o in objects():
            switch_object(o, on)

    times = {(w, on): [] for w in ("plain", "open", "cube") for on in (True, False)}
    for i, (T, start, cube) in enumerate(cases):
        for w in ("plain", "open", "cube"):
            best = {True: float("inf"), False: float("inf")}
            for r in range(6):
                on = r % 2 == 0
                put(on)
                if w == "cube" and fresh:
                    cm._last_scene = NO_SCENE
                    forget_bound_scenes(robot)
                obs = obstacles if w == "open" else [*obstacles, cube]
                t0 = time.process_time()
                if w == "plain":
                    ik.solve(robot, T, start, frame=FRAME, seed=i)
                else:
                    ik.solve(robot, T, start, frame=FRAME, self_collision=True, obstacles=obs, seed=i,
                             max_time=0.5)
                best[on] = min(best[on], time.process_time() - t0)
            for on in (True, False):
                times[(w, on)].append(best[on])
    put(True)
    out = {}
    for on, tag in ((True, "precheck"), (False, "coal")):
        med = {w: float(np.median(times[(w, on)])) * 1e6 for w in ("plain", "open", "cube")}
        out[f"ik_{tag}_median_us"] = med
        out[f"ik_{tag}_open_vs_unconstrained"] = med["open"] / med["plain"]
        out[f"ik_{tag}_cube_vs_unconstrained"] = med["cube"] / med["plain"]
    for w in ("open", "cube"):
        diff = np.array(times[(w, True)]) - np.array(times[(w, False)])
        out[f"ik_{w}_per_target_difference_us"] = float(np.median(diff)) * 1e6
    return out


_SAVED: dict = {}


def switch_object(o, on: bool) -> None:
    """A layout's or scene's pre-check off (None: coal alone) or back on (as built with the object): a layout
    holds it as ``sphere_precheck``, a scene as ``_layout_check`` (the layout's, read by ``precheck()``) and
    reads the classifying kernel as ``_classify`` in ``in_collision``."""
    name = "_layout_check" if hasattr(o, "_layout_check") else "sphere_precheck"
    current = getattr(o, name)
    if current is not None:
        _SAVED[id(o)] = (o, current, getattr(o, "_classify", None))
    saved = _SAVED.get(id(o))
    if saved is None or saved[0] is not o:
        return
    setattr(o, name, saved[1] if on else None)
    if hasattr(o, "_classify"):
        o._classify = saved[2] if on else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--configs", type=int, default=400)
    ap.add_argument("--paths", type=int, default=100)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", help="JSON file for the figures")
    ap.add_argument("--ik", type=int, default=0, help="targets of the IK comparison (0: none)")
    ap.add_argument("--fresh", action="store_true", help="IK comparison: a new cube scene for every solve")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    robot = robots.load("panda")
    obstacles = scene_obstacles()
    scene = robot.collision_scene(obstacles)
    scene.in_collision(robot.neutral())  # builds the workspaces (and the pre-check, when there is one)
    scene.first_collision([robot.neutral()])

    Q = robot.random_q(rng, args.configs)
    truth = coal_truth(scene, robot, Q)
    cert = certified(scene, Q)
    out: dict = {"load_before": open("/proc/loadavg").read().split()[:3], "precheck": cert is not None,
                 "configs": args.configs, "random_in_collision_pct": 100.0 * float(truth.mean())}
    both(out, "in_collision_random", [scene], scene.in_collision, list(Q), args.rounds)
    both(out, "in_collision_free", [scene], scene.in_collision, list(Q[~truth]), args.rounds)
    both(out, "in_collision_colliding", [scene], scene.in_collision, list(Q[truth]), args.rounds)
    if cert is not None:
        both(out, "in_collision_certified", [scene], scene.in_collision, list(Q[cert]), args.rounds)
        both(out, "in_collision_free_uncertified", [scene], scene.in_collision,
             list(Q[~cert & ~truth]), args.rounds)
        out["random_free_certified_pct"] = 100.0 * rate(scene, Q, truth)

    # paths of unconstrained LM runs, in the order the collision-aware IK checks them
    paths, cubes = [], []
    data = robot.model.createData()
    elbow = robot.model.getJointId("panda_joint4")
    while len(paths) < args.paths:
        q = robot.random_q(rng)
        if scene.in_collision(q):
            continue
        res = ik.solve(robot, robot.fk(q, FRAME), robot.random_q(rng), frame=FRAME, seed=len(paths))
        hist = [np.array(h) for h in res.history.iterates()]
        if hist and hist[-1].tolist() == res.q.tolist():
            hist = hist[:-1]
        paths.append([res.q.copy(), *hist[:0:-1]])  # answer, then the iterates last first (start excluded)
        pin.forwardKinematics(robot.model, data, res.q)
        cubes.append(ik.Box(_pose(data.oMi[elbow].translation), (0.1, 0.1, 0.1)))
    lengths = [len(p) for p in paths]
    out["path_length_median"] = float(np.median(lengths))
    flat = np.array([q for p in paths for q in p])
    truth_paths = coal_truth(scene, robot, flat)
    out["path_configs_in_collision_pct"] = 100.0 * float(truth_paths.mean())
    both(out, "first_collision_path", [scene], scene.first_collision, paths, args.rounds)
    if cert is not None:
        out["path_free_certified_pct"] = 100.0 * rate(scene, flat, truth_paths)
        fully = [bool(certified(scene, p).all()) for p in paths]
        out["paths_fully_certified_pct"] = 100.0 * float(np.mean(fully))
    # the same paths with a 10 cm cube on each answer's elbow (every answer then collides with its cube)
    cube_scenes = [robot.collision_scene([*obstacles, c]) for c in cubes]
    for s, p in zip(cube_scenes, paths):
        s.first_collision(p)
    pairs = list(zip(cube_scenes, paths))
    both(out, "first_collision_path_cube", cube_scenes, lambda sp: sp[0].first_collision(sp[1]),
         pairs, args.rounds)
    if cert is not None:
        switch(cube_scenes, True)
        free = cert_n = 0
        for s, p in pairs:
            t = coal_truth(s, robot, p)
            c = certified(s, p)
            assert not np.any(c & t), "a configuration in collision was certified"
            free += int((~t).sum())
            cert_n += int(c[~t].sum())
        out["path_free_certified_cube_pct"] = 100.0 * cert_n / max(free, 1)
    if args.ik and cert is not None:
        out.update(ik_comparison(robot, obstacles, args.ik, args.fresh, args.seed))
    out["load_after"] = open("/proc/loadavg").read().split()[:3]
    for k, v in out.items():
        print(f"{k:36s} {v if not isinstance(v, float) else round(v, 2)}")
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps(out, indent=2))
        print("wrote", args.out)


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    main()
