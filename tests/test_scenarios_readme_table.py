"""kinserve.scenarios.readme_table: number formats, the marker block, the command line.

Each scenario's row is compared with a fresh run of that scenario in its own
test module (``test_readme_row_matches_a_fresh_run``), where the run already exists.
"""

from __future__ import annotations

import json

import pytest

from kinserve import scenarios
from kinserve.kinematics.errors import InputError
from kinserve.scenarios import readme_table as rt


@pytest.mark.parametrize("x, text", [(3.2e-16, "< 1e-15"), (7.4e-16, "< 1e-15"), (1.0e-16, "< 1e-15"),
                                     (5.7e-18, "< 1e-17"), (0.0, "0"), (-2e-14, "< 1e-13"),
                                     (1.5e-6, "1.5e-6"), (2.76e-6, "2.8e-6")])
def test_roundoff_is_a_bound_below_the_floor(x, text):
    assert rt.roundoff(x) == text


def test_sig_keeps_significant_digits():
    assert rt.sig(8.759e-7) == "8.8e-7" and rt.sig(1.96e-4, 1) == "2e-4" and rt.sig(2.14e-8, 1) == "2e-8"


def test_the_scenarios_page_has_one_generated_row_per_scenario():
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "scenarios.md").read_text(encoding="utf-8")
    assert list(rt.readme_rows(text)) == list(scenarios.SCENARIOS)
    assert "../shared/" not in text and "SCENARIOS.md" not in text  # the page stands on its own


def test_replace_table_touches_only_the_block():
    text = f"intro\n{rt.BEGIN}\n| old |\n{rt.END}\noutro\n"
    new = rt.replace_table(text, "| new |")
    assert new == f"intro\n{rt.BEGIN}\n| new |\n{rt.END}\noutro\n"
    assert rt.replace_table(new, "| new |") == new  # idempotent
    with pytest.raises(InputError, match="no generated scenario table"):
        rt.replace_table("no markers here", "| x |")


def test_unknown_scenario_is_an_input_error():
    with pytest.raises(InputError, match="unknown scenario 'S10'"):
        rt.row("S10", {})


def test_main_regenerates_and_checks(tmp_path, monkeypatch, capsys):
    """With canned result.json files: --check reports a stale table, a plain run rewrites it, then --check
    passes."""
    made = {}

    def fake_run(name, out):
        raise AssertionError(f"{name} should not run: its result.json exists")

    monkeypatch.setattr(rt, "run", fake_run)
    canned = {
        "planar4r": {"family_size": 3, "elbow_up": 1, "elbow_down": 2, "max_fk_position_residual": 1e-16,
                     "max_fk_orientation_residual": 2e-16},
        "youbot": {"fk_max_difference": 0.0, "singular": {"rank": 4}, "branches_forward": 2,
                   "branches_above": 3, "off_set_orientation_error": 0.5,
                   "off_reachable": {"orientation_error_bound": 0.5}},
        "youbot-tour": {"visiting_order": "current -> A", "tour_length": 1.0, "max_position_error": 1e-6},
        "pick-place": {"grasp_step": 1, "release_step": 2, "cylinder_release_error": 1e-16,
                       "max_tracking_position_error": 1e-6, "poe_document_max_position_error": 0.01},
        "pr-rate": {"circles": [{"open": {"max_error": 1e-3}, "closed": {"max_error": 1e-6}}],
                    "closed_beats_open_on_all_circles": False, "singular_start_event_step": 0},
        "omni": {"rotation_max_centre_displacement": 0.0, "circle_radius_fit": 0.4, "center_distance": 0.2},
        "mall": {"length": 1.0, "best_order_length": 0.9, "smoothed_length": 0.95, "duration": 3.0},
        "coverage": {"coverage_fraction": 0.5, "length": 12345.0, "max_corner_penetration": 4.1421,
                     "padding": "width"},
        "scara": {"iterations": {"jacobian_inverse": 1, "jacobian_transpose": 2,
                                 "pseudo_inverse": 3, "dls": 4},
                  "min_tool_sphere_distance": 0.25},
    }
    assert set(canned) == set(scenarios.SCENARIOS)
    for name, result in canned.items():
        (tmp_path / "demo" / name).mkdir(parents=True)
        (tmp_path / "demo" / name / "result.json").write_text(json.dumps(result))
        made[name] = rt.row(name, result)
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n{rt.BEGIN}\n| stale |\n{rt.END}\n")
    args = ["--demo", str(tmp_path / "demo"), "--readme", str(readme)]
    assert rt.main([*args, "--check"]) == 1 and "stale" in readme.read_text()
    assert rt.main(args) == 0
    assert rt.readme_rows(readme.read_text()) == made
    assert ("does NOT beat" in made["pr-rate"] and "path 12 345" in made["coverage"]
            and "reach 4.14" in made["coverage"])
    assert rt.main([*args, "--check"]) == 0
    assert "up to date" in capsys.readouterr().out
