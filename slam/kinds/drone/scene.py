"""The 3-D outputs of a drone campaign: the glTF scene and the TUM trajectories of run 0.

    scene.glb      terrain mesh, landmark markers and paths as tubes (:func:`write_scene_glb`)
    <name>.tum     run 0's trajectories (``t x y z qx qy qz qw``) and ``truth.tum``; the
                   first line is a ``#`` comment saying which run (TUM readers skip it)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slam.render.output import tum_text
from slam.render.palette import EIGHT_COLOURS, estimator_colours, filter_names, run0
from slam.results import REFERENCE, CampaignResult

IMU_ONLY = "imu_only"


def drone_colours(result: CampaignResult) -> dict[str, str]:
    """The filters' colours, the smoother's and the IMU-only baseline's."""
    return estimator_colours(filter_names(result), EIGHT_COLOURS, baselines=(IMU_ONLY,))


def result_terrain(result: CampaignResult):
    """The ground of the campaign's world (:class:`nav.terrain.Terrain`)."""
    from slam.kinds.drone.truth import terrain_of

    return terrain_of(result.world)


def tube(points: np.ndarray, radius: float, sides: int = 6):
    """A closed-ring tube mesh along the polyline ``points`` (P, 3) (NaN rows dropped)."""
    import trimesh

    pts = np.asarray(points, dtype=float)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) < 2:  # no path (an estimator that failed from the start)
        return None
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9]
    pts = pts[keep]
    if len(pts) < 2:
        return None
    t = np.gradient(pts, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    ref = np.where(np.abs(t[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    n1 = np.cross(t, ref)
    n1 /= np.linalg.norm(n1, axis=1, keepdims=True)
    n2 = np.cross(t, n1)
    ang = 2.0 * np.pi * np.arange(sides) / sides
    ring = (np.cos(ang)[None, :, None] * n1[:, None] + np.sin(ang)[None, :, None] * n2[:, None])
    verts = (pts[:, None] + radius * ring).reshape(-1, 3)
    i = np.arange(len(pts) - 1)[:, None]
    j = np.arange(sides)[None, :]
    a, b = i * sides + j, i * sides + (j + 1) % sides
    c, d = a + sides, b + sides
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                            np.stack([a, d, c], -1).reshape(-1, 3)])
    return trimesh.Trimesh(verts, faces, process=False)


def _rgba(colour: str, alpha: float = 1.0) -> list[int]:
    from matplotlib.colors import to_rgba

    r, g, b, _ = to_rgba(colour)
    return [int(255 * r), int(255 * g), int(255 * b), int(255 * alpha)]


def write_scene_glb(result: CampaignResult, path: str | Path) -> Path:
    """``scene.glb``: terrain mesh, true landmarks (gold spheres), each estimator's final
    landmarks (small spheres in its colour) and run 0's paths as tubes."""
    import trimesh

    first = run0(result)
    colours = drone_colours(result)
    scene = trimesh.Scene()
    ground = result_terrain(result).mesh.copy()
    z = ground.vertices[:, 2]
    span = max(float(np.ptp(z)), 1e-9)
    shade = ((z - z.min()) / span)[:, None]
    low, high = np.array(_rgba("#6b8e23")), np.array(_rgba("#c2b280"))
    ground.visual.vertex_colors = (low + shade * (high - low)).astype(np.uint8)
    scene.add_geometry(ground, node_name="terrain", geom_name="terrain")
    for i, p in enumerate(first.true_landmarks):
        s = trimesh.creation.icosphere(subdivisions=1, radius=0.8)
        s.apply_translation(p)
        s.visual.face_colors = _rgba("gold")
        scene.add_geometry(s, node_name=f"landmark_{i}", geom_name=f"landmark_{i}")
    paths = [("truth", first.truth[:, :3], "black", 0.18)]
    for name in [*filter_names(result), REFERENCE]:
        tr = first.tracks.get(name)
        if tr is not None:
            paths.append((name, tr.p, colours[name], 0.12))
            for j, p in zip(tr.landmark_ids, tr.landmarks):
                s = trimesh.creation.icosphere(subdivisions=1, radius=0.35)
                s.apply_translation(p)
                s.visual.face_colors = _rgba(colours[name])
                label = f"{name}_landmark_{int(j)}"
                scene.add_geometry(s, node_name=label, geom_name=label)
    for name, pts, colour, radius in paths:
        mesh = tube(pts, radius)
        if mesh is not None:
            mesh.visual.face_colors = _rgba(colour)
            scene.add_geometry(mesh, node_name=f"path_{name}", geom_name=f"path_{name}")
    path = Path(path)
    path.write_bytes(scene.export(file_type="glb"))
    return path


def tum_text_3d(times: np.ndarray, p: np.ndarray, q: np.ndarray, header: str = "") -> str:
    """TUM lines ``t x y z qx qy qz qw`` (scalar-last), non-finite rows left out, after
    ``header`` as ``#`` comment lines."""
    ok = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(q), axis=1)
    return tum_text(np.column_stack([times[ok], p[ok], q[ok][:, 1:], q[ok][:, :1]]), header)


def _pose(o, name: str):
    """(p, q_wxyz, 6 x 6 pose covariance) of ``name`` on run ``o``."""
    if name == "truth":
        return o.truth[:, :3], o.truth[:, 6:10], None
    tr = o.tracks[name]
    return tr.p, tr.q, tr.pose_cov


def write_tum_3d(result: CampaignResult, out_dir: Path) -> list[str]:
    """``truth.tum``, ``<name>.tum`` and ``<name>.cov.txt`` for every estimator on each
    tracked run (run 0; every run with ``--tum all``: :mod:`slam.render.tum`)."""
    from slam.render import tum

    return tum.write_all(result, out_dir, list(result.outcomes[0].tracks), _pose,
                         "ENU, q = q_nb (body to navigation frame); poses at the filter epochs",
                         "t, then the 6 x 6 covariance of [position (m, ENU), attitude rotation"
                         " vector (rad, body frame: q = q̂ ⊗ Exp(δθ))] row-major")
