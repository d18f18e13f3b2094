"""The README gallery: one plot per scenario and screenshots of the 3-D scenes.

    python -m kinserve.scenarios.gallery [--demo DIR] [--out scenarios/gallery]

Runs every scenario into ``--demo`` (default ``demo-out``) unless its
``result.json`` is already there, copies the chosen PNG of each into
``--out`` and renders the pick-and-place and SCARA scenes in headless
Chromium (``viz.screenshot``). ``make gallery`` calls this.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from . import SCENARIOS, run

#: scenario -> the plot shown in the README
CHOSEN = {
    "planar4r": "family.png",
    "youbot": "branches.png",
    "youbot-tour": "path.png",
    "pick-place": "tracking_errors.png",
    "pr-rate": "circles.png",
    "omni": "circle.png",
    "mall": "map.png",
    "coverage": "coverage.png",
    "scara": "relax_z_near_sphere.png",
}
# scene -> ms of animation played before the capture (0 = first frame)
SCREENSHOTS = {"pick-place": 7000, "scara": 0}


def main(argv=None) -> int:
    """Command-line entry point (see the module docstring); returns the exit status (0)."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--demo", default="demo-out")
    ap.add_argument("--out", default=str(Path(__file__).parent / "gallery"))
    args = ap.parse_args(argv)
    demo, out = Path(args.demo), Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in SCENARIOS:
        if not (demo / name / "result.json").exists():
            run(name, demo / name)
        pngs = sorted((demo / name).glob("*.png"))
        chosen = demo / name / CHOSEN[name]
        src = chosen if chosen.exists() else pngs[0]
        shutil.copy(src, out / f"{name}.png")
        print(f"{name}: {src}")
    from kinserve.viz import screenshot

    for name, played_ms in SCREENSHOTS.items():
        png = screenshot(demo / name / "scene.html", out / f"{name}-scene.png", size=(900, 600),
                         play=played_ms > 0, settle_ms=played_ms)
        print(f"{name} scene: {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
