"""The scenario table of docs/scenarios.md, generated from each scenario's ``result.json``.

    python -m kinserve.scenarios.readme_table [--demo DIR] [--readme docs/scenarios.md] [--check]

Reads ``DIR/NAME/result.json`` for every scenario (running the scenarios
that have none yet, as ``kinserve demo`` would), builds one Markdown row per
scenario (:func:`row`) and replaces the block between :data:`BEGIN` and
:data:`END` in the page (``--readme``, default ``docs/scenarios.md``). ``--check`` changes nothing and
exits with 1 when the page's table differs from the results. The tests compare each row with
a fresh run of its scenario, so the page's numbers cannot drift from the code.

Numbers at round-off level are written as a bound (``< 1e-15``), which holds
on every machine; the others keep two to four significant digits.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path

from kinserve.kinematics.errors import InputError

from . import SCENARIOS, run

BEGIN = ("<!-- scenario-table: generated from demo-out/*/result.json by `python -m "
         "kinserve.scenarios.readme_table` -->")
END = "<!-- /scenario-table -->"
HEADER = "| scenario | what it shows | key numbers (demo defaults) |\n|---|---|---|"

#: scenario -> seed label and what the scenario demonstrates (prose, not numbers)
SHOWS: dict[str, tuple[str, str]] = {
    "planar4r": ("S1", "redundant 4R: the one-parameter IK family with both elbow branches, "
                       "a chooser by joint-limit distance / displacement / manipulability / no self-overlap, "
                       "the collapse at the workspace boundary"),
    "youbot": ("S2", "DH FK = URDF model; 6×5 Jacobian = column formula; rank (never `det`) finds the q3 = 0 "
                     "singularity; closed-form branches incl. reach-over-the-back; "
                     "nearest reachable pose for a 6-D target off the 5-D set"),
    "youbot-tour": ("S3", "checkpoints read from JSON/CSV, exact shortest order (Euclidean, not ½·squared), "
                          "decoupled SE(3) interpolation, position-only IK warm started, "
                          "`trajectory.json`/`.csv`"),
    "pick-place": ("S4", "Panda: SE(3) quintic segments with boundary twists (not the seed's global "
                         "exponential-coordinate cubic), DLS tracking with Pinocchio's Jacobian, "
                         "grasp/release events, cylinder carried in the animation"),
    "pr-rate": ("S5", "resolved-rate table of runs, singularity detected (θ2 = 90° at step 0) and damped, "
                      "circle following open vs closed loop"),
    "omni": ("S6", "three-wheel omni base: heading-dependent (not position-dependent) wheel kinematics, "
                   "`solve_ivp` simulation"),
    "mall": ("S7", "A* (8-connected, optimal) through the waypoints, best order of the intermediate ones, "
                   "smoothed path clear of the inflated obstacles, time scaling with a turn-rate cap"),
    "coverage": ("S8", "boustrophedon lanes of 20 with detours, no-go zones, smooth U-turns; "
                       "the turning 20×20 footprint's reach into obstacles is measured "
                       "(`padding=\"diagonal\"` pads by 10√2 instead)"),
    "scara": ("S9", "Jacobian inverse / transpose / pseudo-inverse / DLS histories; relax φ → θ4 centred; "
                    "relax z → d3 centred at 0.625 unless the sphere (0.4, −0.7, 0.5), r 0.2 binds, "
                    "never entered on any iterate"),
}


def roundoff(x: float, floor: float = 1e-12) -> str:
    """``"< 1e-15"`` (the next power of ten above) for ``|x| < floor``, else ``x`` with two significant
    digits."""
    x = abs(float(x))
    if x < floor:
        return "0" if x == 0 else f"< 1e{math.floor(math.log10(x)) + 1}"
    return f"{x:.1e}".replace("e-0", "e-")


def sig(x: float, digits: int = 2) -> str:
    """``x`` in ``digits`` significant digits, scientific notation (``2.1e-8``)."""
    return f"{float(x):.{digits - 1}e}".replace("e-0", "e-").replace("e+00", "")


def _planar4r(r: Mapping) -> str:
    residual = max(r["max_fk_position_residual"], r["max_fk_orientation_residual"])
    return (f"{r['family_size']} family members ({r['elbow_up']} up, {r['elbow_down']} down), "
            f"FK residual {roundoff(residual)}")


def _youbot(r: Mapping) -> str:
    off = r["off_reachable"]
    return (f"DH vs URDF {roundoff(r['fk_max_difference'])}; rank {r['singular']['rank']} at q3 = 0; "
            f"closed-form branches: {r['branches_forward']} for a target in front, "
            f"{r['branches_above']} above the base; nearest pose's orientation error "
            f"{r['off_set_orientation_error']:.4f} rad = its lower bound "
            f"{off['orientation_error_bound']:.4f}")


def _tour(r: Mapping) -> str:
    order = r["visiting_order"].replace(" -> ", "→")
    return f"order {order}, {r['tour_length']:.3f} m; max position error {sig(r['max_position_error'])} m"


def _pick_place(r: Mapping) -> str:
    return (f"grasp step {r['grasp_step']}, release step {r['release_step']}; cylinder ends "
            f"{roundoff(r['cylinder_release_error'])} m from the release pose; max tracking error "
            f"{sig(r['max_tracking_position_error'])} m; document's screw axes off by "
            f"{1e3 * r['poe_document_max_position_error']:.1f} mm")


def _pr_rate(r: Mapping) -> str:
    circles = r["circles"]
    beats = "beats" if r["closed_beats_open_on_all_circles"] else "does NOT beat"
    first = circles[0]
    return (f"closed loop {beats} open loop on all {len(circles)} circles (circle 1: "
            f"{sig(first['open']['max_error'], 1)} → {sig(first['closed']['max_error'], 1)} m); "
            f"singular start found at step {r['singular_start_event_step']}")


def _omni(r: Mapping) -> str:
    return ("equal wheels → rotation in place (centre moves "
            f"{roundoff(r['rotation_max_centre_displacement'])} m); "
            f"one wheel → circle r = {r['circle_radius_fit']:.4f} m (2D = {2 * r['center_distance']:g} m)")


def _mall(r: Mapping) -> str:
    return (f"{r['length']:.1f} given order, {r['best_order_length']:.1f} best order, "
            f"{r['smoothed_length']:.1f} smoothed, {r['duration']:.0f} s")


def _coverage(r: Mapping) -> str:
    length = f"{r['length']:,.0f}".replace(",", " ")  # 10 161
    return (f"{100 * r['coverage_fraction']:.1f} % of the free floor, path {length}; "
            f"footprint corners reach {r['max_corner_penetration']:.2f} into obstacles/walls (padding "
            f"{r['padding']})")


def _scara(r: Mapping) -> str:
    it = r["iterations"]
    counts = " / ".join(str(it[m])
                        for m in ("jacobian_inverse", "jacobian_transpose", "pseudo_inverse", "dls"))
    return f"iterations {counts}; min tool–sphere distance {r['min_tool_sphere_distance']:.6f}"


#: scenario -> the "key numbers" cell, computed from its result.json
KEY_NUMBERS: dict[str, Callable[[Mapping], str]] = {
    "planar4r": _planar4r, "youbot": _youbot, "youbot-tour": _tour, "pick-place": _pick_place,
    "pr-rate": _pr_rate, "omni": _omni, "mall": _mall, "coverage": _coverage, "scara": _scara,
}


def row(name: str, result: Mapping) -> str:
    """The Markdown table row of scenario ``name`` for its ``result.json`` contents."""
    if name not in KEY_NUMBERS:
        raise InputError(f"unknown scenario {name!r}; known: {', '.join(KEY_NUMBERS)}")
    label, shows = SHOWS[name]
    return f"| `{name}` ({label}) | {shows} | {KEY_NUMBERS[name](result)} |"


def table(results: Mapping[str, Mapping]) -> str:
    """The whole table (header and one row per scenario, in :data:`SCENARIOS` order)."""
    return "\n".join([HEADER, *(row(name, results[name]) for name in SCENARIOS)])


def readme_rows(text: str) -> dict[str, str]:
    """The generated rows found in a page's text: scenario name -> row."""
    block = _block(text)[1]
    rows = {}
    for line in block.splitlines():
        if line.startswith("| `"):
            rows[line.split("`", 2)[1]] = line
    return rows


def _block(text: str) -> tuple[int, str, int]:
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise InputError(f"no generated scenario table (markers {BEGIN!r} ... {END!r})")
    body_start = start + len(BEGIN)
    return body_start, text[body_start:end], end


def replace_table(text: str, new_table: str) -> str:
    """``text`` with the block between the markers replaced by ``new_table``."""
    body_start, _, end = _block(text)
    return text[:body_start] + "\n" + new_table.strip("\n") + "\n" + text[end:]


def load_results(demo: Path) -> dict[str, dict]:
    """``result.json`` of every scenario under ``demo``; scenarios without one are run first."""
    results = {}
    for name in SCENARIOS:
        path = demo / name / "result.json"
        if not path.exists():
            run(name, demo / name)
        results[name] = json.loads(path.read_text(encoding="utf-8"))
    return results


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point (see the module docstring): 0, or 1 when ``--check`` finds the table stale."""
    ap = argparse.ArgumentParser(
        description="Regenerate the scenario table of docs/scenarios.md from demo results.")
    ap.add_argument("--demo", default="demo-out",
                    help="folder of `kinserve demo all` output (default demo-out)")
    ap.add_argument("--readme", default="docs/scenarios.md",
                    help="the Markdown page holding the table (default docs/scenarios.md)")
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 if the page differs")
    args = ap.parse_args(argv)
    readme = Path(args.readme)
    text = readme.read_text(encoding="utf-8")
    new = replace_table(text, table(load_results(Path(args.demo))))
    if new == text:
        print(f"{readme}: scenario table up to date")
        return 0
    if args.check:
        print(f"{readme}: scenario table differs from {args.demo}/*/result.json")
        return 1
    readme.write_text(new, encoding="utf-8")
    print(f"{readme}: scenario table regenerated from {args.demo}/*/result.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
