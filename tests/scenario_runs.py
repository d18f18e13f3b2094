"""Running a seed scenario once per test module."""

import json

from kinserve import scenarios


def run_scenario(tmp_path_factory, name: str):
    """Run scenario ``name`` into a fresh temporary folder: ``(folder, result.json as a dict)``."""
    out = tmp_path_factory.mktemp(name)
    scenarios.run(name, out)
    return out, json.loads((out / "result.json").read_text())


def assert_readme_row(name: str, result: dict) -> None:
    """The README's scenario-table row of ``name`` is the row that this fresh ``result.json`` produces."""
    from pathlib import Path

    from kinserve.scenarios import readme_table

    readme = Path(__file__).resolve().parents[1] / "README.md"
    rows = readme_table.readme_rows(readme.read_text(encoding="utf-8"))
    assert name in rows, f"README.md has no generated row for {name}"
    assert rows[name] == readme_table.row(name, result), (
        f"README.md's {name} row differs from a fresh run; regenerate it with "
        "`kinserve demo all --out demo-out && python -m kinserve.scenarios.readme_table --demo demo-out`")
