"""Models kept on disk (opendyn.io.model_cache): a second load of the same files returns the
stored Model without reading the URDF, and any change to a file it was made from (the URDF, a
mesh, the SRDF), to the options or to the entry itself builds it again."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import warnings

import numpy as np
import pytest

import opendyn as od
from opendyn.io import model_cache

from test_urdf import chain, collision, link, robot  # noqa: E402

MESH = {"filename": "cube.obj"}
CUBE = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """The model cache in a folder of the test's own; returns the folder."""
    folder = tmp_path / "models"
    monkeypatch.setattr(model_cache, "_folder", lambda: folder)
    return folder


def write_cube(path, side=2.0):
    half = side / 2
    lines = [f"v {x * half} {y * half} {z * half}" for x, y, z in CUBE]
    faces = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]
    lines += [f"f {a} {b} {c}\nf {a} {c} {d}" for a, b, c, d in faces]
    path.write_text("\n".join(lines) + "\n")


def arm(tmp_path, mass=1.5):
    """A 2-link chain whose last link has an OBJ cube as collision mesh."""
    text = chain(2, links={1: {"mass": mass}, 2: {"extra": collision("mesh", MESH)}})
    if not (tmp_path / "cube.obj").exists():
        write_cube(tmp_path / "cube.obj")
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    return path


def same_model(a, b):
    for name in ("_ibuf", "_fbuf"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert [g.name for g in a.geometries] == [g.name for g in b.geometries]
    assert str(a.report) == str(b.report)


def test_a_second_load_returns_the_stored_model_without_building_it(tmp_path, cache, monkeypatch):
    path = arm(tmp_path)
    first = od.load_urdf(path)
    assert len(list(cache.glob("*.pkl"))) == 1
    monkeypatch.setattr("opendyn.io.urdf.read_urdf", lambda *a: pytest.fail("read again"))
    second = od.load_urdf(path)
    same_model(first, second)
    q = np.array([0.3, -0.2])
    assert np.allclose(od.mass_matrix(first, q), od.mass_matrix(second, q))


def test_a_new_process_loads_the_stored_model_without_importing_the_urdf_reader(tmp_path):
    path = arm(tmp_path)
    code = (
        "import sys, numpy as np, opendyn as od\n"
        f"m = od.load_urdf({str(path)!r})\n"
        "print('yourdfpy' in sys.modules, np.array2string(m._fbuf, threshold=10**6))"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [
        subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        for _ in range(2)
    ]
    first, second = (run.stdout.split(" ", 1) for run in runs)
    assert first[0] == "True" and second[0] == "False", [run.stderr for run in runs]
    assert first[1] == second[1]


def test_a_changed_urdf_or_mesh_or_option_builds_the_model_again(tmp_path, cache):
    path = arm(tmp_path)
    before = od.load_urdf(path)
    mesh = next(g for g in before.geometries if g.shape == "mesh")
    assert np.abs(mesh.vertices).max() == 1.0
    write_cube(tmp_path / "cube.obj", side=4.0)  # the mesh changed
    grown = next(g for g in od.load_urdf(path).geometries if g.shape == "mesh")
    assert np.abs(grown.vertices).max() == 2.0
    arm(tmp_path, mass=3.0)  # the URDF changed
    heavier = od.load_urdf(path)
    assert not np.array_equal(heavier._fbuf, before._fbuf)
    floating = od.load_urdf(path, floating_base=True)  # another option
    assert floating.floating_base and not heavier.floating_base
    assert len(list(cache.glob("*.pkl"))) == 2  # one entry per (URDF, options)


def test_a_changed_srdf_builds_the_model_again(tmp_path, cache):
    urdf = tmp_path / "arm.urdf"
    ball = {"extra": collision("sphere", {"radius": 0.1})}
    urdf.write_text(chain(3, links={1: ball, 2: ball, 3: ball}))
    srdf = tmp_path / "arm.srdf"
    srdf.write_text('<robot name="r"><disable_collisions link1="link1" link2="link3"/></robot>')
    pairs = od.load_urdf(urdf, srdf=srdf).collision_pairs
    srdf.write_text('<robot name="r"></robot>')
    assert len(od.load_urdf(urdf, srdf=srdf).collision_pairs) == len(pairs) + 1


def test_an_entry_cut_short_is_a_miss(tmp_path, cache):
    path = arm(tmp_path)
    model = od.load_urdf(path)
    (entry,) = cache.glob("*.pkl")
    entry.write_bytes(entry.read_bytes()[:100])
    same_model(model, od.load_urdf(path))
    assert pickle.loads(entry.read_bytes())[0] == model_cache.FORMAT  # stored whole again


def test_a_load_that_warns_warns_every_time_and_is_not_stored(tmp_path, cache):
    path = tmp_path / "r.urdf"
    path.write_text(robot(link("base", mass=1.0)))

    def build():
        warnings.warn("something odd", UserWarning)
        return "model"

    for _ in range(2):
        with pytest.warns(UserWarning, match="something odd"):
            assert model_cache.cached_model(str(path), None, (False,), build) == "model"
    assert not list(cache.glob("*.pkl"))


def test_the_cache_can_be_switched_off(tmp_path, monkeypatch):
    monkeypatch.setenv("OPENDYN_MODEL_CACHE", "0")
    assert model_cache._folder() is None


def test_a_large_world_mesh_says_it_computes_its_hull_and_keeps_it(tmp_path, cache, capsys,
                                                                     monkeypatch):
    """A [[world]] mesh of over 100k vertices: the first scene announces its hull on stderr;
    the next loads the hull from the cache, computing none (hull_vertices is not called)."""
    import trimesh

    from opendyn.io.scene import sections_world

    # 81920 triangles: an STL of 245760 corners
    trimesh.creation.icosphere(subdivisions=6, radius=1.0).export(tmp_path / "ball.stl")
    data = {
        "objects": [{"name": "box", "shape": "box", "size": [0.2, 0.2, 0.2], "mass": 1.0,
                     "position": [0.0, 0.0, 2.0]}],
        "world": [{"name": "ball", "shape": "mesh", "mesh": "ball.stl", "size": [2, 2, 2]}],
        "effects": {"gravity": True, "contact": {"geometry": "collision", "stiffness": 1e4,
                                       "friction": 0.5}},
    }

    def ball():
        scene = od.scene_from_dict(data, base_dir=tmp_path)
        return next(g for g in scene.model.geometries if g.name == "ball")

    first = ball()
    err = capsys.readouterr().err
    assert "computing the convex hull of the world mesh" in err and "ball.stl" in err, err
    assert "(245760 vertices" in err and np.abs(first.vertices).max() == pytest.approx(2.0)

    def refused(*args):
        raise AssertionError("the hull was computed again")

    monkeypatch.setattr(sections_world, "hull_vertices", refused)
    again = ball()
    assert np.array_equal(again.vertices, first.vertices)
    assert "computing the convex hull" not in capsys.readouterr().err
    data["world"][0]["size"] = [1, 1, 1]  # another scale: another entry
    with pytest.raises(AssertionError, match="computed again"):
        ball()
