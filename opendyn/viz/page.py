"""The self-contained playback page: ``_SceneRecorder`` stands in for meshcat's viewer window,
keeps the scene that a Visualizer's commands build, and writes it out as meshcat's static HTML
export (the viewer's JavaScript, the geometry and the animation inlined; no network access), with
the camera and a caption.
"""

from __future__ import annotations

import base64
import pathlib

import numpy as np

from .camera import CAMERA_FOV


class _SceneRecorder:
    """Stands in for meshcat's viewer window: keeps the scene that a Visualizer's commands
    build (as meshcat's server does) and writes it out as meshcat's static HTML export, so no
    server process or network port is needed to write a page."""

    web_url = None

    def __init__(self):
        self.nodes: dict[tuple, bytes] = {}  # (kind, path[, property]) -> packed command
        self.animation: bytes | None = None

    def send(self, command):
        import umsgpack

        data = command.lower()
        packed = umsgpack.packb(data)
        kind, path = data["type"], data["path"]
        if kind == "delete":
            prefix = path.rstrip("/") + "/"
            self.nodes = {
                k: v for k, v in self.nodes.items() if k[1] != path and not k[1].startswith(prefix)
            }
        elif kind == "set_animation":
            self.animation = packed
        elif kind == "set_property":
            self.nodes[(kind, path, data["property"])] = packed
        else:
            if kind == "set_object":  # a new object forgets the old one's properties
                self.nodes = {
                    k: v
                    for k, v in self.nodes.items()
                    if not (k[0] == "set_property" and k[1] == path)
                }
            self.nodes[(kind, path)] = packed

    def commands(self):
        order = {"set_object": 0, "set_property": 1, "set_transform": 2}
        items = sorted(self.nodes.items(), key=lambda kv: order[kv[0][0]])
        out = [v for _, v in items]
        if self.animation is not None:
            out.append(self.animation)
        return out

    def page(self, title, camera, caption=""):
        """The page: ``title``, the (target, position) ``camera``, and a ``caption`` line at the
        bottom left (none when "")."""
        import meshcat

        js_file = pathlib.Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        viewer_js = js_file.read_text(encoding="utf-8")
        lines = [
            f'command("{base64.b64encode(packed).decode("ascii")}");' for packed in self.commands()
        ]
        target, position = camera
        return _PAGE.format(
            title=_html_escape(title),
            caption=_CAPTION.format(text=_html_escape(caption)) if caption else "",
            viewer_js=viewer_js,
            commands="\n".join(lines),
            target=_three_js(target),
            position=_three_js(position),
            fov=CAMERA_FOV,
        )

    def get_scene(self):  # what Visualizer.static_html() asks its window for
        return self.page("opendyn playback", (np.zeros(3), np.array([3.0, 0.0, 1.0])))


def _three_js(p_s):
    """A point of meshcat's world (z up) in three.js's world (y up), as JavaScript numbers."""
    x, y, z = (float(c) for c in p_s)
    return f"{x:.6g}, {z:.6g}, {-y:.6g}"


def _html_escape(text):
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


_CAPTION = """
<div id="opendyn-caption" style="position: absolute; left: 8px; bottom: 8px; padding: 2px 6px; \
font: 13px sans-serif; color: #222; background: rgba(255, 255, 255, 0.75);">{text}</div>"""

_PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>{caption}
<script>
{viewer_js}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
// meshcat commands (msgpack, base64), applied in order without any fetch
function command(b64) {{
  var s = atob(b64), bytes = new Uint8Array(s.length);
  for (var i = 0; i < s.length; i++) bytes[i] = s.charCodeAt(i);
  try {{
    viewer.handle_command_bytearray(bytes);
  }} catch (e) {{
    console.error("opendyn playback: a scene command failed:", e);
  }}
}}
{commands}
// camera: orbiting about the robot's centre; its coordinates are three.js's world (y up),
// which is meshcat's world (z up) as (x, z, -y)
(function () {{
  var camera = viewer.camera;
  camera.fov = {fov};
  camera.position.set({position});
  viewer.controls.target.set({target});
  viewer.controls.update();
  viewer.set_dirty();
}})();
</script>
</body>
</html>
"""
