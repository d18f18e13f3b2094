"""Every Python snippet of the README and of docs/ runs as written.

Each Markdown file's ```python blocks run in order in one fresh namespace (a guide builds on its earlier
blocks), in a subprocess whose working directory is a temporary folder (snippets that write files write
there). A block that is not meant to run is preceded by ``<!-- not-run: reason -->``; the reason is
required. The MkDocs navigation lists every page under docs/, so no page is left out of the site.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FENCE = re.compile(r"^```(\S*)\s*$")
NOT_RUN = re.compile(r"^<!--\s*not-run:(.*?)-->\s*$")
#: seconds for one file's blocks together (the slowest guide takes ~20 s on a 2-core machine)
FILE_TIMEOUT = 240

RUNNER = """
import json, sys
blocks = json.loads(sys.stdin.read())
namespace = {"__name__": "__main__"}
for line, code in blocks:
    exec(compile(code, f"{sys.argv[1]}:{line}", "exec"), namespace)
"""


def markdown_files() -> list[Path]:
    """README.md and every Markdown page under docs/."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def python_blocks(text: str) -> list[tuple[int, str, str | None]]:
    """``(line of the opening fence, code, skip reason or None)`` of each ```python block in ``text``."""
    lines = text.splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i].strip())
        if not m or not m.group(1):
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
        if m.group(1) == "python":
            indent = len(lines[i]) - len(lines[i].lstrip())
            code = "\n".join(s[indent:] for s in lines[i + 1:end])
            before = next((s.strip() for s in reversed(lines[:i]) if s.strip()), "")
            skip = NOT_RUN.match(before)
            blocks.append((i + 1, code, skip.group(1).strip() if skip else None))
        i = end + 1
    return blocks


def test_block_parser_reads_fences_indents_and_skips():
    text = ("# t\n```python\nx = 1\n```\n\n<!-- not-run: needs a server -->\n```python\nboom()\n```\n"
            "- item:\n  ```python\n  y = x + 1\n  ```\n```bash\nls\n```\n"
            "<!-- not-run: -->\n\n```python\nz\n```\n")
    assert python_blocks(text) == [(2, "x = 1", None), (7, "boom()", "needs a server"),
                                   (11, "y = x + 1", None), (19, "z", "")]


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_skipped_block_states_why(path):
    for line, _, reason in python_blocks(path.read_text(encoding="utf-8")):
        assert reason is None or reason, f"{path.name}:{line}: <!-- not-run: --> needs a reason"


def test_the_readme_and_the_guides_have_snippets_that_run():
    runnable = {p.name for p in markdown_files() if runnable_blocks(p)}
    assert {"README.md", "getting-started.md", "robots.md", "kinematics.md", "ik.md", "motion-planning.md",
            "mobile.md", "service.md"} <= runnable


def runnable_blocks(path: Path) -> list[tuple[int, str]]:
    """``(line, code)`` of the blocks of ``path`` that run (not marked not-run)."""
    return [(line, code) for line, code, reason in python_blocks(path.read_text(encoding="utf-8"))
            if reason is None]


@pytest.mark.parametrize("path", [p for p in markdown_files() if runnable_blocks(p)],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_snippets_run(path, tmp_path):
    blocks = runnable_blocks(path)
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.run([sys.executable, "-c", RUNNER, str(path.relative_to(ROOT))],
                          input=json.dumps(blocks), cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=FILE_TIMEOUT)
    assert proc.returncode == 0, f"a snippet of {path.name} failed:\n{proc.stderr[-4000:]}"


def _nav_pages(nav) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, dict):
        return [p for v in nav.values() for p in _nav_pages(v)]
    return [p for item in nav for p in _nav_pages(item)]


def test_the_site_navigation_lists_every_page():
    import yaml

    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    pages = {str(p.relative_to(ROOT / config["docs_dir"])) for p in (ROOT / "docs").rglob("*.md")}
    assert sorted(_nav_pages(config["nav"])) == sorted(pages)
