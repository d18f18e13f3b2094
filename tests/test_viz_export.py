"""kinserve.viz.export_html: one self-contained, offline HTML file holding meshcat's viewer and the scene."""

import re

import numpy as np
import pytest

from kinserve import robots
from kinserve import viz
from kinserve.kinematics import InputError
from kinserve.viz.export import VIEWER_JS, pack_commands, unpack_commands


@pytest.fixture(scope="module")
def panda_scene():
    panda = robots.load("panda")
    scene = viz.Scene("export test")
    scene.add_robot(panda, panda.neutral())
    scene.add_sphere("ball", [0.4, -0.3, 0.4], 0.08)
    pts = np.array([panda.fk(q)[:3, 3] for q in np.linspace(panda.neutral(), panda.neutral() + 0.4, 10)])
    scene.add_path("tip", pts)
    anim = viz.Animation(scene, fps=25)
    anim.robot("panda", np.linspace(panda.neutral(), panda.neutral() + 0.4, 10))
    anim.apply()
    return scene


def test_html_is_self_contained_and_holds_viewer_scene_and_animation(panda_scene, tmp_path):
    path = viz.export_html(panda_scene, tmp_path / "out" / "scene.html")
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    # no external resources: no script/img/link sources, no stylesheets, no fetches over the network
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.I)
    assert not re.search(r"\b(src|href)\s*=\s*[\"']?(https?:)?//", text, re.I)
    assert "<link" not in text.lower() and "@import" not in text
    assert not re.search(r"fetch\(\s*[\"']https?:", text)
    # meshcat's viewer bundle is inlined verbatim
    assert VIEWER_JS.read_text(encoding="utf-8") in text
    assert "new MeshCat.Viewer(" in text and "handle_command_bytearray" in text
    # the embedded commands are exactly the scene's, animation included
    cmds = viz.read_html_commands(path)
    assert cmds == panda_scene.commands()
    anim = [c for c in cmds if c["type"] == "set_animation"]
    assert len(anim) == 1 and len(anim[0]["animations"]) == len(panda_scene.robots["panda"].nodes)
    dae = [c for c in cmds if c["type"] == "set_object" and c["object"]["object"].get("format") == "dae"]
    assert len(dae) == 11 and all("<COLLADA" in c["object"]["object"]["data"] for c in dae)
    assert 'data-commands="%d"' % len(cmds) in text
    assert "<title>export test</title>" in text


def test_gzip_and_raw_payloads_decode_to_the_same_commands(panda_scene):
    packed = viz.static_html(panda_scene)
    raw = viz.static_html(panda_scene, compress=False, title="raw")
    assert 'data-encoding="gzip"' in packed and 'data-encoding="raw"' in raw
    assert viz.read_html_commands(packed) == viz.read_html_commands(raw) == panda_scene.commands()
    assert len(packed) < 0.6 * len(raw)  # the .dae meshes compress well


def test_pack_roundtrip_and_errors():
    cmds = [{"type": "set_property", "path": "/a", "property": "visible", "value": bool(i % 2)} for i in range(5)]
    assert unpack_commands(pack_commands(cmds)) == cmds
    with pytest.raises(InputError):
        viz.static_html("not a scene")
    with pytest.raises(InputError, match="kinserve"):
        viz.read_html_commands("<html><body>nothing</body></html>")


def test_title_is_escaped(tmp_path):
    scene = viz.Scene("<b>a & b</b>")
    scene.add_sphere("s", [0, 0, 0], 0.1)
    text = viz.export_html(scene, tmp_path / "t.html").read_text()
    assert "<title>&lt;b&gt;a &amp; b&lt;/b&gt;</title>" in text
