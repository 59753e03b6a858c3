"""Terrain meshes: height lookup and line of sight (nav.terrain)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from nav.terrain import Terrain, hills_height, segments_hit_triangles


def ridge() -> Terrain:
    """A 10 m ridge along the y axis (x = 0), 1 m grid."""
    return Terrain.from_function(lambda X, Y: 10.0 * np.exp(-X**2 / 18.0), (-40, 40, -40, 40),
                                 1.0)


def test_occlusion_by_a_ridge():
    t = ridge()
    ground = lambda x, y: float(t.height([x, y]))  # noqa: E731
    a = np.array([
        [-20.0, 0.0, 2.0],     # low, across the ridge: hidden
        [-20.0, 0.0, 30.0],    # high above the ridge: visible
        [-20.0, 5.0, 2.0],     # same side as the target: visible
        [-20.0, -10.0, 2.0],   # along the ridge's flank, same side: visible
        [-20.0, 20.0, 12.0],   # across, 12 m up, target far behind: grazes the crest
        [-3.0, 0.0, 20.0],     # above the flank, looking over the crest down the far side
    ])
    b = np.array([
        [20.0, 0.0, ground(20.0, 0.0)],
        [20.0, 0.0, ground(20.0, 0.0)],
        [-5.0, 5.0, ground(-5.0, 5.0)],
        [-20.0, 10.0, ground(-20.0, 10.0)],
        [20.0, 20.0, ground(20.0, 20.0)],
        [6.0, 0.0, ground(6.0, 0.0)],
    ])
    vis = t.line_of_sight(a, b, margin=0.1)
    assert vis.tolist() == [False, True, True, True, False, True]
    # without the margin a target lying on the surface occludes itself
    assert not t.line_of_sight(a[2], b[2], margin=0.0)[0]
    # the geometric truth: a straight line from (-20, 0, 2) to (20, 0, ~0) passes x = 0 at
    # about 1 m, far below the 10 m crest
    assert ground(0.0, 0.0) == pytest.approx(10.0)


def test_line_of_sight_is_vectorised_and_chunked():
    t = ridge()
    rng = np.random.default_rng(1)
    a = np.column_stack([rng.uniform(-30, 30, (300, 2)), rng.uniform(1, 25, 300)])
    xy = rng.uniform(-30, 30, (300, 2))
    b = np.column_stack([xy, t.height(xy)])
    full = t.line_of_sight(a, b, 0.1)
    small = t.line_of_sight(a, b, 0.1, chunk=7)
    one = np.array([t.line_of_sight(a[i], b[i], 0.1)[0] for i in range(0, 300, 37)])
    assert np.array_equal(full, small) and np.array_equal(full[::37], one)
    assert 0.1 < full.mean() < 0.95  # both kinds present


def test_height_lookup_on_hills_and_flat():
    c = [[10.0, 5.0], [-12.0, 20.0]]
    t = Terrain.hills((-30, 30, -30, 30), c, 6.0, 8.0, base=2.0, spacing=1.0)
    xs = np.linspace(-30, 30, 61)
    X, Y = np.meshgrid(xs[::7], xs[::5])
    assert np.allclose(t.height(np.stack([X, Y], -1)), 2.0 + hills_height(X, Y, c, 6.0, 8.0),
                       atol=1e-9)  # exact at the grid vertices
    pts = np.random.default_rng(0).uniform(-29, 29, (500, 2))
    h = t.height(pts)
    assert np.max(np.abs(h - 2.0 - hills_height(pts[:, 0], pts[:, 1], c, 6.0, 8.0))) < 0.1
    assert np.isnan(t.height([[100.0, 0.0]])).all()
    f = Terrain.flat((0.0, 100.0, 0.0, 100.0), 3.5)
    assert np.allclose(f.height([[0.0, 0.0], [50.0, 77.0], [100.0, 100.0]]), 3.5)
    assert f.line_of_sight([10.0, 10.0, 8.5], [50.0, 50.0, 3.5], 0.1).all()


def test_mesh_file_round_trip(tmp_path):
    t = Terrain.hills((0, 20, 0, 20), [[10.0, 10.0]], 4.0, 3.0, spacing=2.0)
    path = tmp_path / "field.obj"
    t.mesh.export(path)
    u = Terrain.from_file(path)
    pts = np.random.default_rng(2).uniform(0.5, 19.5, (50, 2))
    assert np.allclose(u.height(pts), t.height(pts), atol=1e-6)
    bad = tmp_path / "empty.obj"
    bad.write_text("# nothing\n")
    with pytest.raises(ValueError):
        Terrain.from_file(bad)


def test_moller_trumbore_edges():
    tri = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]] * 4)
    a = np.array([[0.2, 0.2, 1.0], [0.2, 0.2, 1.0], [0.8, 0.8, 1.0], [0.2, 0.2, 0.0]])
    b = np.array([[0.2, 0.2, -1.0], [0.2, 0.2, 0.5], [0.8, 0.8, -1.0], [0.6, 0.2, 0.0]])
    # through; stops short; misses (outside); lies in the plane (a miss by convention)
    assert segments_hit_triangles(a, b, tri).tolist() == [True, False, False, False]
    assert isinstance(ridge().mesh, trimesh.Trimesh)
