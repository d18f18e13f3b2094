"""Running a seed scenario once per test module, keeping the figures it saved."""

import json
from pathlib import Path

from kinserve import scenarios

from figure_checks import capture_figures

#: scenario output folder -> {png file name: the matplotlib Figure saved there}
FIGURES: dict[Path, dict] = {}


def run_into(out, name: str, **options) -> dict:
    """``scenarios.run(name, out, **options)``, recording its figures in :data:`FIGURES`."""
    with capture_figures() as figs:
        result = scenarios.run(name, out, **options)
    FIGURES[Path(out)] = figs
    return result


def run_scenario(tmp_path_factory, name: str):
    """Run scenario ``name`` into a fresh temporary folder: ``(folder, result.json as a dict)``."""
    out = tmp_path_factory.mktemp(name)
    run_into(out, name)
    return out, json.loads((out / "result.json").read_text())


def figures(out) -> dict:
    """``{png name: Figure}`` saved by the scenario run into ``out``."""
    return FIGURES[Path(out)]

def assert_readme_row(name: str, result: dict) -> None:
    """docs/scenarios.md's table row of ``name`` is the row that this fresh ``result.json`` produces."""
    from pathlib import Path

    from kinserve.scenarios import readme_table

    readme = Path(__file__).resolve().parents[1] / "docs" / "scenarios.md"
    rows = readme_table.readme_rows(readme.read_text(encoding="utf-8"))
    assert name in rows, f"docs/scenarios.md has no generated row for {name}"
    assert rows[name] == readme_table.row(name, result), (
        f"docs/scenarios.md's {name} row differs from a fresh run; regenerate it with "
        "`kinserve demo all --out demo-out && python -m kinserve.scenarios.readme_table --demo demo-out`")
