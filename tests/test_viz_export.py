"""kinserve.viz.export_html: one self-contained, offline HTML file holding meshcat's viewer and the scene."""

import importlib
import re

import numpy as np
import pytest

from kinserve import robots, viz
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
    cmds = [{"type": "set_property", "path": "/a", "property": "visible", "value": bool(i % 2)}
            for i in range(5)]
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


def wcag_luminance(rgb) -> float:
    """WCAG 2 relative luminance of an sRGB colour given as 0-255 channels."""
    c = np.asarray(rgb, dtype=float) / 255.0
    lin = np.where(c <= 0.03928, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return float(0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2])


def contrast_ratio(a, b) -> float:
    la, lb = sorted((wcag_luminance(a), wcag_luminance(b)), reverse=True)
    return (la + 0.05) / (lb + 0.05)


def css_colour(value: str):
    """(r, g, b in 0-255, alpha) of a CSS colour: #rgb, #rrggbb, rgb(...) or rgba(...)."""
    value = value.strip()
    m = re.fullmatch(r"#([0-9a-fA-F]{3}|[0-9a-fA-F]{6})", value)
    if m:
        h = m.group(1) if len(m.group(1)) == 6 else "".join(ch * 2 for ch in m.group(1))
        return np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)], dtype=float), 1.0
    m = re.fullmatch(r"rgba?\(([^)]*)\)", value)
    assert m, f"unparsed CSS colour {value!r}"
    parts = [float(p) for p in m.group(1).split(",")]
    return np.array(parts[:3]), (parts[3] if len(parts) == 4 else 1.0)


def caption_style(text: str) -> dict:
    rule = re.search(r"#kinserve-status\s*\{([^}]*)\}", text).group(1)
    return {k.strip(): v.strip() for k, v in (d.split(":", 1) for d in rule.split(";") if ":" in d)}


def test_caption_is_readable_over_the_scene_background(panda_scene, tmp_path):
    """WCAG contrast >= 4.5 between the caption's text and what is behind it, from the page as written:
    its CSS, and the background gradient the page's own commands set (over black and white too)."""
    path = viz.export_html(panda_scene, tmp_path / "caption.html")
    text = path.read_text(encoding="utf-8")
    style = caption_style(text)
    fg, fg_alpha = css_colour(style["color"])
    assert fg_alpha == 1.0
    backdrop = style.get("background-color", style.get("background", "rgba(0, 0, 0, 0)"))
    bd, bd_alpha = css_colour(backdrop)
    gradient = {c["property"]: np.array(c["value"]) * 255 for c in viz.read_html_commands(path)
                if c["path"] == "/Background" and c["type"] == "set_property"}
    assert set(gradient) == {"top_color", "bottom_color"}
    behind = [gradient["top_color"], gradient["bottom_color"], np.zeros(3), np.full(3, 255.0)]
    for scene_colour in behind:
        seen = bd_alpha * bd + (1 - bd_alpha) * scene_colour  # the backdrop composited over the scene
        ratio = contrast_ratio(fg, seen)
        assert ratio >= 4.5, f"caption contrast {ratio:.2f} over {scene_colour}"
    # the formula itself: black on white is 21, a colour on itself 1, and the old grey on midnight blue fails
    assert contrast_ratio([0, 0, 0], [255, 255, 255]) == pytest.approx(21.0)
    assert contrast_ratio([51, 51, 51], [51, 51, 51]) == pytest.approx(1.0)
    assert contrast_ratio([0x33, 0x33, 0x33], gradient["bottom_color"]) < 4.5


@pytest.mark.parametrize("kwargs, message", [
    ({"size": (800,)}, r"size must be \(width, height\)"), ({"size": "800x600"}, r"size must be \(width"),
    ({"size": (800.5, 600)}, "size width must be an integer"), ({"size": (800, 0)}, "size height must be an"),
    ({"size": (10**5, 600)}, "size width must be an integer from 16 to 8,192"),
    ({"play": "no"}, "play must be True or False"), ({"capture": 0}, "capture must be True or False"),
    ({"settle_ms": -5}, "settle_ms must be zero or positive"),
    ({"settle_ms": float("nan")}, "settle_ms must be finite"),
    ({"timeout": 0}, "timeout must be positive"), ({"timeout": 1e5}, "timeout must be at most 3600"),
])
def test_render_refuses_bad_arguments_before_it_starts_a_browser(tmp_path, monkeypatch, kwargs, message):
    """Each argument of the headless render is checked first: ``size=(800.5, 600)`` was cut to 800,
    ``play="no"`` played the animation, ``settle_ms=-5`` raised Python's ``sleep length must be
    non-negative`` after the page had loaded. ``screenshot`` and ``page_status`` pass theirs on."""
    module = importlib.import_module("kinserve.viz.screenshot")
    page = viz.export_html(viz.Scene(), tmp_path / "page.html")
    started = []
    monkeypatch.setattr(module, "find_browser", lambda: started.append(1))
    with pytest.raises(InputError, match=message):
        module.render(page, **kwargs)
    if "capture" not in kwargs:
        with pytest.raises(InputError, match=message):
            viz.screenshot(page, tmp_path / "page.png", **kwargs)
    if set(kwargs) <= {"play", "timeout"}:
        with pytest.raises(InputError, match=message):
            viz.page_status(page, **kwargs)
    assert started == []


@pytest.mark.parametrize("call, message", [
    (lambda p: viz.Scene(title=3), "title must be a str, got 3"),
    (lambda p: viz.static_html(viz.Scene(), title=np.zeros(0)), "title must be a str or None"),
    (lambda p: viz.export_html(viz.Scene(), 3), "path must be a file path"),
    (lambda p: viz.planar_arm_figure([1.0], {"a": [[0.0]]}, title=True), "title must be a str"),
])
def test_titles_and_the_export_path_are_checked(tmp_path, call, message):
    """``Scene(title=3)`` was shown as "3", an array title raised NumPy's ambiguous-truth error, a number as
    the export path Python's TypeError."""
    with pytest.raises(InputError, match=message):
        call(tmp_path)
    assert "<title>t &amp; u</title>" in viz.static_html(viz.Scene(), title="t & u")
