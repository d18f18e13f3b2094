"""Static export: a :class:`viz.Scene` as one self-contained HTML file.

The file holds meshcat's viewer (``meshcat/viewer/dist/main.min.js`` from the
installed ``meshcat`` package, inlined: no network access, no external
``src``) and the scene's commands (:meth:`Scene.commands`), each packed with
msgpack exactly as meshcat's server sends them over its websocket. The
commands are concatenated as ``[u32 big-endian length][msgpack bytes]``
records, gzip-compressed (robot meshes are text ``.dae`` files, which shrink
about 3x) and base64-encoded into the page. On load, a small script decodes
them (``DecompressionStream('gzip')``, in every current browser) and replays
them, in order, into ``viewer.handle_command_bytearray``; the animation, if
any, then starts playing (meshcat's "Animations" panel replays it; open
``page.html#paused`` to load it without playing, showing the first frame).

Progress is written into ``<div id="kinserve-status">``: ``data-status`` is
``loading``, then ``ready`` (with ``data-commands``, the number replayed, and
``data-animation-clips`` / ``data-animation-duration``, what meshcat's
animator loaded) or ``error`` (with ``data-error``); uncaught errors are
counted in ``data-errors``, so a headless browser's ``--dump-dom`` tells
whether the page loaded cleanly (:func:`viz.screenshot.page_status`).
"""

from __future__ import annotations

import base64
import gzip
import html
import os
import struct
from pathlib import Path

import meshcat
import umsgpack

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_flag, as_path, as_text

from .scene import Scene

#: Caption (the page title, then the load status) at the bottom left: near-black text on a
#: nearly opaque white backdrop, readable over any part of the scene (the background gradient
#: ends in midnight blue at the bottom; WCAG contrast ratio above 12 even over black).
CAPTION_TEXT = "#1a1a1a"
CAPTION_BACKDROP = "rgba(255, 255, 255, 0.88)"

#: The meshcat viewer bundle shipped inside the ``meshcat`` Python package.
VIEWER_JS = Path(meshcat.__file__).resolve().parent / "viewer" / "dist" / "main.min.js"

_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="generator" content="kinserve viz.export_html (meshcat static export)">
<title>{title}</title>
<style>
  body {{ margin: 0; }}
  #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
  #kinserve-status {{ position: absolute; left: 8px; bottom: 6px; padding: 2px 6px; border-radius: 3px;
                     font: 12px sans-serif; color: {caption_text}; background-color: {caption_backdrop}; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="kinserve-status" data-status="loading" data-errors="0">{title}</div>
<script>
(function () {{
  var status = document.getElementById("kinserve-status");
  window.addEventListener("error", function (e) {{
    status.setAttribute("data-errors", String(Number(status.getAttribute("data-errors")) + 1));
    status.setAttribute("data-error", String(e.message));
  }});
}})();
</script>
<script>
{viewer_js}
</script>
<script id="kinserve-scene" type="application/octet-stream"
        data-encoding="{encoding}" data-commands="{count}">{payload}</script>
<script>
(function () {{
  var status = document.getElementById("kinserve-status");
  var node = document.getElementById("kinserve-scene");
  var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  window.viewer = viewer;
  function fromBase64(text) {{
    var bin = atob(text.replace(/\\s+/g, ""));
    var out = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }}
  function replay(bytes) {{
    var view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    var offset = 0, count = 0;
    while (offset < bytes.byteLength) {{
      var n = view.getUint32(offset, false);
      offset += 4;
      viewer.handle_command_bytearray(bytes.subarray(offset, offset + n));
      offset += n;
      count += 1;
    }}
    status.setAttribute("data-commands", String(count));
    var animator = viewer.animator;
    if (animator && /(^#|&)paused(&|$)/.test(window.location.hash)) {{
      animator.pause();  // "page.html#paused": show the first frame, do not play
      animator.reset();
    }}
    status.setAttribute("data-animation-clips", String(animator ? animator.actions.length : 0));
    status.setAttribute("data-animation-duration", String(animator ? animator.duration : 0));
    status.setAttribute("data-animation-playing", String(Boolean(animator && animator.playing)));
    status.setAttribute("data-status", "ready");
  }}
  function fail(err) {{
    status.setAttribute("data-status", "error");
    status.setAttribute("data-error", String(err && err.message ? err.message : err));
    status.textContent = "could not load the scene: " + status.getAttribute("data-error");
  }}
  try {{
    var raw = fromBase64(node.textContent);
    if (node.getAttribute("data-encoding") === "gzip") {{
      if (typeof DecompressionStream === "undefined") {{
        fail("this browser lacks DecompressionStream (gzip); use a current Chrome, Firefox or Safari");
        return;
      }}
      var stream = new Blob([raw]).stream().pipeThrough(new DecompressionStream("gzip"));
      new Response(stream).arrayBuffer().then(function (buf) {{
        try {{ replay(new Uint8Array(buf)); }} catch (e) {{ fail(e); }}
      }}, fail);
    }} else {{
      replay(raw);
    }}
  }} catch (e) {{
    fail(e);
  }}
}})();
</script>
</body>
</html>
"""


def pack_commands(commands) -> bytes:
    """``[u32 big-endian length][msgpack]`` records of the lowered commands."""
    out = bytearray()
    for cmd in commands:
        data = umsgpack.packb(cmd)
        out += struct.pack(">I", len(data))
        out += data
    return bytes(out)


def unpack_commands(blob: bytes) -> list[dict]:
    """Inverse of :func:`pack_commands`."""
    cmds, offset = [], 0
    while offset < len(blob):
        (n,) = struct.unpack_from(">I", blob, offset)
        offset += 4
        cmds.append(umsgpack.unpackb(blob[offset:offset + n]))
        offset += n
    return cmds


def static_html(scene: Scene, *, title: str | None = None, compress: bool = True) -> str:
    """The HTML text of the static export (see the module docstring)."""
    if not isinstance(scene, Scene):
        raise InputError(f"static_html needs a viz.Scene, got {type(scene).__name__}")
    title = as_text(title, "title", optional=True)
    commands = scene.commands()
    blob = pack_commands(commands)
    if as_flag(compress, "compress"):
        blob = gzip.compress(blob, compresslevel=6, mtime=0)
    payload = base64.b64encode(blob).decode("ascii")
    payload = "\n".join(payload[i:i + 4096] for i in range(0, len(payload), 4096))
    viewer_js = VIEWER_JS.read_text(encoding="utf-8")
    if "</script" in viewer_js.lower():  # would end the inline <script> early
        viewer_js = viewer_js.replace("</script", "<\\/script").replace("</SCRIPT", "<\\/SCRIPT")
    return _TEMPLATE.format(
        title=html.escape(title or scene.title),
        caption_text=CAPTION_TEXT,
        caption_backdrop=CAPTION_BACKDROP,
        viewer_js=viewer_js,
        encoding="gzip" if compress else "raw",
        count=len(commands),
        payload=payload,
    )


def export_html(scene: Scene, path, *, title: str | None = None, compress: bool = True) -> Path:
    """Write the scene as a self-contained static HTML file at ``path``; returns the path.

    The file opens offline in a browser (``file://``), shows the scene with
    meshcat's orbit controls, and plays the scene's animation. ``path``: a ``str`` or ``os.PathLike``;
    ``title``: None (the scene's) or a str (:class:`InputError` otherwise).
    """
    path = as_path(path, "export_html: path")
    if path.parent and not path.parent.exists():
        os.makedirs(path.parent, exist_ok=True)
    text = static_html(scene, title=title, compress=compress)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
    return path


def read_html_commands(source) -> list[dict]:
    """The commands embedded in an exported HTML file (a path or the HTML text)."""
    text = (source if isinstance(source, str) and source.lstrip().startswith("<")
            else Path(source).read_text(encoding="utf-8"))
    start_tag = '<script id="kinserve-scene"'
    i = text.find(start_tag)
    if i < 0:
        raise InputError("not a kinserve static export: no <script id=\"kinserve-scene\"> block")
    head_end = text.index(">", i)
    body_end = text.index("</script>", head_end)
    head = text[i:head_end]
    blob = base64.b64decode("".join(text[head_end + 1:body_end].split()))
    if 'data-encoding="gzip"' in head:
        blob = gzip.decompress(blob)
    return unpack_commands(blob)
