"""``kinserve demo NAME|all [--out DIR] [--open]``: run the seed scenarios and write their artefacts."""

from __future__ import annotations

import argparse
import json
import webbrowser
from pathlib import Path


def _summary(result: dict) -> str:
    keys = [k for k, v in result.items() if isinstance(v, (int, float, bool, str)) and k not in ("scenario",)]
    return ", ".join(f"{k}={result[k]:.6g}" if isinstance(result[k], float) else f"{k}={result[k]}"
                     for k in keys[:8])


def cmd_demo(args) -> int:
    """``kinserve demo``: run one scenario (or all) into ``--out``; returns the exit status."""
    from kinserve import scenarios

    variant = "planned" if getattr(args, "planned", False) else None
    names = list(scenarios.SCENARIOS) if args.name == "all" else [args.name]
    if variant is not None and args.name == "all":
        names = [n for n in names if variant in scenarios.VARIANTS.get(n, {})]
    out = Path(args.out)
    results = {}
    for name in names:
        label = name if variant is None else f"{name}-{variant}"
        folder = out / label
        result = scenarios.run(name, folder, variant=variant)
        results[label] = result
        if args.json:
            continue
        desc = scenarios.SCENARIOS[name][1] if variant is None else scenarios.VARIANTS[name][variant][1]
        print(f"[{label}] {desc}")
        print(f"    {_summary(result)}")
        for path in sorted(folder.iterdir()):
            print(f"    {path}")
        if args.open and (folder / "scene.html").exists():
            webbrowser.open((folder / "scene.html").resolve().as_uri())
    if args.json:
        from kinserve.scenarios.artefacts import plain

        print(json.dumps(plain(results), indent=2))
    else:
        print(f"\nartefacts in {out.resolve()}  (open */scene.html in a browser, */*.png for plots)")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command to ``sub``."""
    from kinserve import scenarios

    p = sub.add_parser("demo", help="run a seed scenario (or all) and write its results, plots and scenes")
    p.add_argument("name", choices=[*scenarios.SCENARIOS, "all"], metavar="NAME",
                   help="one of: " + ", ".join([*scenarios.SCENARIOS, "all"]))
    p.add_argument("--out", default="demo-out", help="output folder (default ./demo-out)")
    p.add_argument("--open", action="store_true", help="open each scene.html in the default browser")
    p.add_argument("--json", action="store_true", help="print all results as JSON")
    p.add_argument("--planned", action="store_true",
                   help="run the planned variant into OUT/NAME-planned (pick-place: the cylinder carried on "
                        "a planned motion around the box); with all, every scenario that has one")
    p.set_defaults(func=cmd_demo)
