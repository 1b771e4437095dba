"""Playback of a motion in meshcat: a self-contained HTML page (``write_html``) or a live viewer
(``view``). meshcat is an optional dependency (``pip install 'opendyn[viz]'``), imported only when
a playback function runs.

The modules, each on those above it:
  visuals        the URDF's visual geometry, ready to draw (load_visuals, resolve_mesh)
  motion         the motion checked and resampled to the frame rate, as quaternion tracks
  meshcat_scene  the meshcat scene: geometry posed over time, the ground, contact-force arrows
  camera         where the camera stands to frame the motion
  page           meshcat's static HTML export of a scene, without a server
  playback       write_html and view
"""

from .meshcat_scene import MESHCAT_HINT
from .motion import resample
from .playback import view, write_html
from .visuals import DEFAULT_RGBA, PlaybackWarning, load_visuals, resolve_mesh

__all__ = [
    "DEFAULT_RGBA",
    "MESHCAT_HINT",
    "PlaybackWarning",
    "load_visuals",
    "resample",
    "resolve_mesh",
    "view",
    "write_html",
]
