"""scenarios: the nine seed systems of SCENARIOS.md, end to end.

Each module has ``run(out: pathlib.Path, **options) -> dict``: it computes the
scenario with the library, writes its artefacts (PNG plots, ``scene.html``
for the 3-D ones, data files) into ``out`` and returns its key numbers as
plain data. :func:`run` adds ``result.json`` (that dict) to the folder.

    kinserve demo NAME [--out DIR]       one scenario into DIR/NAME/
    kinserve demo all --out DIR          all of them
    kinserve demo NAME --planned         its planned variant (:data:`VARIANTS`) into DIR/NAME-planned/
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

from .artefacts import write_json

#: name -> (module, one-line description)
SCENARIOS: dict[str, tuple[str, str]] = {
    "planar4r": ("kinserve.scenarios.planar4r",
                 "S1 redundant 4R planar arm: the one-parameter IK family, both elbow branches, a chooser"),
    "youbot": ("kinserve.scenarios.youbot",
               "S2 KUKA youBot 5-DOF: DH FK = URDF, Jacobian rank, closed-form IK branches, "
               "nearest reachable pose"),
    "youbot-tour": ("kinserve.scenarios.youbot_tour",
                    "S3 youBot checkpoint tour: shortest order, SE(3) interpolation, "
                    "position-only IK trajectory"),
    "pick-place": ("kinserve.scenarios.pick_place",
                   "S4 Franka Panda pick-and-place: SE(3) quintic trajectories with boundary twists, "
                   "DLS tracking, grasp/release"),
    "pr-rate": ("kinserve.scenarios.pr_rate",
                "S5 PR planar robot: resolved-rate runs, singularity detection, "
                "circle following open vs closed loop"),
    "omni": ("kinserve.scenarios.omni",
             "S6 three-wheel omnidirectional base: wheel-speed kinematics and simulated motion"),
    "mall": ("kinserve.scenarios.mall",
             "S7 cleaning robot in a mall: A* between waypoints, best order, smoothing and time scaling"),
    "coverage": ("kinserve.scenarios.coverage",
                 "S8 cleaning robot floor coverage: boustrophedon lanes, detours, covered fraction"),
    "scara": ("kinserve.scenarios.scara",
              "S9 SCARA RRPR: Jacobian methods, relaxed phi / z with joint centring and a sphere obstacle"),
}

#: name -> {variant: (module, one-line description)}: other versions of a scenario, run by
#: ``run(name, out, variant=...)`` (``kinserve demo NAME --planned``); not part of ``kinserve demo all``.
VARIANTS: dict[str, dict[str, tuple[str, str]]] = {
    "pick-place": {"planned": ("kinserve.scenarios.pick_place_planned",
                               "S4 planned: the cylinder carried on a planned motion around the open box, "
                               "straight-line approach / retreat, clearance along the whole trajectory")},
}


def available() -> dict[str, str]:
    """Scenario names with their one-line descriptions."""
    return {name: desc for name, (_, desc) in SCENARIOS.items()}


def run(name: str, out, variant: str | None = None, **options) -> dict:
    """Run scenario ``name`` (its ``variant`` of :data:`VARIANTS` when given) into folder ``out`` (created),
    write ``result.json``, return the result."""
    from kinserve.kinematics.errors import InputError, suggest

    if name not in SCENARIOS:
        raise InputError(f"unknown scenario {name!r}.{suggest(name, SCENARIOS)} Known: "
                         f"{', '.join(SCENARIOS)}")
    if variant is not None and variant not in VARIANTS.get(name, {}):
        raise InputError(f"scenario {name!r} has no variant {variant!r}; its variants: "
                         f"{sorted(VARIANTS.get(name, {}))}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    module = importlib.import_module(SCENARIOS[name][0] if variant is None else VARIANTS[name][variant][0])
    t0 = time.perf_counter()
    result = module.run(out, **options)
    result = dict(result)
    result.setdefault("scenario", name)
    if variant is not None:
        result.setdefault("variant", variant)
    result["elapsed_s"] = round(time.perf_counter() - t0, 3)
    write_json(out / "result.json", result)
    return result
