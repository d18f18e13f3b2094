"""Running a seed scenario once per test module."""

import json

from kinserve import scenarios


def run_scenario(tmp_path_factory, name: str):
    """Run scenario ``name`` into a fresh temporary folder: ``(folder, result.json as a dict)``."""
    out = tmp_path_factory.mktemp(name)
    scenarios.run(name, out)
    return out, json.loads((out / "result.json").read_text())
