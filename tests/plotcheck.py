"""Checks of a saved plot beyond its file's first bytes: the figure it was saved from (captured
at savefig) holds the data it was asked to draw, and the image read back is that figure's size,
is not blank, and shows the colours of the lines drawn."""

from __future__ import annotations

import contextlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors  # noqa: E402
import matplotlib.figure  # noqa: E402
import matplotlib.image  # noqa: E402
import numpy as np  # noqa: E402


@contextlib.contextmanager
def saved_figures():
    """A list that fills with (figure, dpi) for every figure saved inside the block."""
    saved = []
    save = matplotlib.figure.Figure.savefig

    def savefig(self, *args, **kwargs):
        saved.append((self, kwargs.get("dpi", matplotlib.rcParams["savefig.dpi"])))
        return save(self, *args, **kwargs)

    matplotlib.figure.Figure.savefig = savefig
    try:
        yield saved
    finally:
        matplotlib.figure.Figure.savefig = save


def read_png(path, figure, dpi):
    """The PNG at path as (H, W, 3) floats in [0, 1], checked to be `figure` at `dpi` (its size
    in pixels) and not blank: at least 2% of its pixels are not the white background."""
    image = matplotlib.image.imread(path)[..., :3]
    width, height = np.round(figure.get_size_inches() * float(dpi)).astype(int)
    assert image.shape[:2] == (height, width), (image.shape, width, height)
    ink = (image < 0.95).any(axis=-1).mean()
    assert ink > 0.02, f"{path}: {ink:.1%} of the pixels drawn"
    return image


def pixels_of(image, colour, tol=0.03):
    """How many pixels of image are `colour` (any matplotlib colour), within tol per channel."""
    rgb = np.array(matplotlib.colors.to_rgb(colour))
    return int((np.abs(image - rgb).max(axis=-1) < tol).sum())


def assert_lines_shown(image, lines, least=30):
    """Each of `lines` (matplotlib Line2D) has at least `least` pixels of its colour."""
    for line in lines:
        n = pixels_of(image, line.get_color())
        assert n >= least, f"{line.get_label()!r} ({line.get_color()}): {n} pixels of its colour"
