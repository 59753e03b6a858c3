r"""Terrain as a triangle mesh: height lookup and line of sight (occlusion).

A :class:`Terrain` wraps a :class:`trimesh.Trimesh` whose surface is the ground, in the
ENU navigation frame (z up).  Three ways to build one:

* :meth:`Terrain.flat` - a level plane (two triangles);
* :meth:`Terrain.hills` - a regular grid mesh of a sum of Gaussian bumps,
  :math:`z(x, y) = z_0 + A \sum_i \exp(-\lVert (x, y) - c_i \rVert^2 / 2w^2)`,
  fully determined by its parameters (no randomness);
* :meth:`Terrain.from_file` / :meth:`Terrain.from_mesh` - any triangle mesh trimesh reads
  (OBJ, PLY, STL, GLB, ...), e.g. a surveyed field.

Queries are vectorised and need nothing beyond numpy (no ``rtree``/``embree``):

* :meth:`Terrain.height` - the highest surface point above each ``(x, y)``, found through
  a uniform 2-D bucket grid of the triangles' footprints and a barycentric test;
* :meth:`Terrain.line_of_sight` - segment-versus-mesh intersection (Möller-Trumbore) of
  many segments at once, candidate triangles first culled by bounding boxes.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

__all__ = ["Terrain", "segments_hit_triangles"]

_EPS = 1e-12


def segments_hit_triangles(a: Array, b: Array, tri: Array) -> NDArray[np.bool_]:
    r"""Möller-Trumbore test of segment ``a[i] -> b[i]`` against triangle ``tri[i]``.

    Parameters
    ----------
    a, b : (P, 3) arrays - segment end points; tri : (P, 3, 3) - triangle vertices.

    Returns
    -------
    (P,) bool: the segment meets the (closed) triangle at a parameter
    :math:`t \in [0, 1]`.  A segment lying in the triangle's plane counts as a miss.
    """
    d = b - a
    v0 = tri[:, 0]
    e1 = tri[:, 1] - v0
    e2 = tri[:, 2] - v0
    pvec = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pvec)
    ok = np.abs(det) > _EPS * (np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
                               * np.linalg.norm(d, axis=1) + _EPS)
    inv = 1.0 / np.where(ok, det, 1.0)
    tvec = a - v0
    u = np.einsum("ij,ij->i", tvec, pvec) * inv
    qvec = np.cross(tvec, e1)
    v = np.einsum("ij,ij->i", d, qvec) * inv
    t = np.einsum("ij,ij->i", e2, qvec) * inv
    return ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t >= 0.0) & (t <= 1.0)


@dataclass(frozen=True, eq=False)
class Terrain:
    """The ground surface as a triangle mesh, with vectorised height and occlusion queries.

    Build with :meth:`flat`, :meth:`hills`, :meth:`from_heights`, :meth:`from_file` or
    :meth:`from_mesh`; ``bucket_m`` is the cell size of the 2-D bucket grid used by
    :meth:`height` (default: about two triangle footprints).
    """

    mesh: trimesh.Trimesh
    bucket_m: float | None = None
    _tri: Array = field(init=False, repr=False)
    _lo: Array = field(init=False, repr=False)
    _hi: Array = field(init=False, repr=False)
    _grid: tuple = field(init=False, repr=False)

    def __post_init__(self) -> None:
        tri = np.asarray(self.mesh.triangles, dtype=np.float64)
        if tri.ndim != 3 or tri.shape[0] == 0:
            raise ValueError("terrain mesh has no triangles")
        object.__setattr__(self, "_tri", tri)
        object.__setattr__(self, "_lo", tri.min(axis=1))
        object.__setattr__(self, "_hi", tri.max(axis=1))
        object.__setattr__(self, "_grid", self._bucket_grid())

    # ------------------------------------------------------------------ constructors

    @classmethod
    def from_mesh(cls, mesh: trimesh.Trimesh) -> Terrain:
        """Wrap an existing mesh (vertices in the ENU frame, metres)."""
        return cls(mesh)

    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> Terrain:
        """Read a mesh file; scenes are flattened into one mesh."""
        loaded = trimesh.load(os.fspath(path), force="mesh")
        if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
            raise ValueError(f"{os.fspath(path)}: no triangle mesh in the file")
        return cls(loaded)

    @classmethod
    def from_heights(cls, x: ArrayLike, y: ArrayLike, Z: ArrayLike) -> Terrain:
        """A grid mesh through heights ``Z[i, j]`` at ``(x[j], y[i])`` (increasing axes)."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        Z = np.asarray(Z, dtype=np.float64)
        if Z.shape != (len(y), len(x)) or len(x) < 2 or len(y) < 2:
            raise ValueError(f"heights must have shape (len(y), len(x)) >= (2, 2), got {Z.shape}")
        X, Y = np.meshgrid(x, y)
        verts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
        nx = len(x)
        i, j = np.meshgrid(np.arange(len(y) - 1), np.arange(nx - 1), indexing="ij")
        v00 = (i * nx + j).ravel()
        v01, v10, v11 = v00 + 1, v00 + nx, v00 + nx + 1
        faces = np.concatenate([np.column_stack([v00, v01, v11]),
                                np.column_stack([v00, v11, v10])])  # counter-clockwise: up
        return cls(trimesh.Trimesh(verts, faces, process=False),
                   bucket_m=float(max(np.diff(x).max(), np.diff(y).max())))

    @classmethod
    def from_function(cls, fn: Callable[[Array, Array], Array],
                      bounds: tuple[float, float, float, float], spacing: float) -> Terrain:
        """Grid mesh of ``z = fn(X, Y)`` over ``bounds = (xmin, xmax, ymin, ymax)``."""
        xmin, xmax, ymin, ymax = bounds
        nx = max(int(np.ceil((xmax - xmin) / spacing)), 1) + 1
        ny = max(int(np.ceil((ymax - ymin) / spacing)), 1) + 1
        x = np.linspace(xmin, xmax, nx)
        y = np.linspace(ymin, ymax, ny)
        X, Y = np.meshgrid(x, y)
        return cls.from_heights(x, y, fn(X, Y))

    @classmethod
    def flat(cls, bounds: tuple[float, float, float, float], height: float = 0.0) -> Terrain:
        """A level plane at ``height`` over ``bounds`` (two triangles)."""
        xmin, xmax, ymin, ymax = bounds
        return cls.from_heights([xmin, xmax], [ymin, ymax], np.full((2, 2), float(height)))

    @classmethod
    def hills(cls, bounds: tuple[float, float, float, float], centres: ArrayLike,
              amplitude: float, width: float, base: float = 0.0,
              spacing: float = 2.0) -> Terrain:
        """Sum of Gaussian bumps (module docstring) on a grid of ``spacing`` metres."""
        c = np.asarray(centres, dtype=np.float64).reshape(-1, 2)

        def fn(X: Array, Y: Array) -> Array:
            return base + hills_height(X, Y, c, amplitude, width)

        return cls.from_function(fn, bounds, spacing)

    # ------------------------------------------------------------------ queries

    def _bucket_grid(self) -> tuple:
        lo, hi = self._lo[:, :2], self._hi[:, :2]
        x0, y0 = lo.min(axis=0)
        x1, y1 = hi.max(axis=0)
        cell = self.bucket_m
        if cell is None:
            ext = np.median(np.maximum(hi - lo, 1e-9), axis=0).max()
            cell = 2.0 * float(ext)
        cell = max(cell, 1e-6)
        nx = max(int(np.ceil((x1 - x0) / cell)), 1)
        ny = max(int(np.ceil((y1 - y0) / cell)), 1)
        ix0 = np.clip(((lo[:, 0] - x0) / cell).astype(int), 0, nx - 1)
        ix1 = np.clip(((hi[:, 0] - x0) / cell).astype(int), 0, nx - 1)
        iy0 = np.clip(((lo[:, 1] - y0) / cell).astype(int), 0, ny - 1)
        iy1 = np.clip(((hi[:, 1] - y0) / cell).astype(int), 0, ny - 1)
        cx, cy = ix1 - ix0 + 1, iy1 - iy0 + 1
        count = cx * cy
        tri_idx = np.repeat(np.arange(len(count)), count)
        start = np.repeat(np.cumsum(count) - count, count)
        local = np.arange(count.sum()) - start
        cells = (iy0[tri_idx] + local // cx[tri_idx]) * nx + ix0[tri_idx] + local % cx[tri_idx]
        order = np.argsort(cells, kind="stable")
        cells, tri_idx = cells[order], tri_idx[order]
        per_cell = np.bincount(cells, minlength=nx * ny)
        width = int(per_cell.max())
        table = np.full((nx * ny, width), -1, dtype=np.int64)
        first = np.cumsum(per_cell) - per_cell
        table[cells, np.arange(len(cells)) - first[cells]] = tri_idx
        return (float(x0), float(y0), float(x1), float(y1), cell, nx, ny, table)

    def height(self, xy: ArrayLike) -> Array:
        """Ground height under each point ``xy`` (..., 2); NaN outside the mesh footprint.

        Where surfaces overlap (overhangs) the highest one is returned.
        """
        pts = np.asarray(xy, dtype=np.float64)
        shape = pts.shape[:-1]
        pts = pts.reshape(-1, 2)
        x0, y0, x1, y1, cell, nx, ny, table = self._grid
        with np.errstate(invalid="ignore"):
            inside = (pts[:, 0] >= x0) & (pts[:, 0] <= x1) & (pts[:, 1] >= y0) & (pts[:, 1] <= y1)
        xy = np.where(inside[:, None], pts, [[x0, y0]])
        ix = np.minimum(np.floor((xy[:, 0] - x0) / cell).astype(np.int64), nx - 1)
        iy = np.minimum(np.floor((xy[:, 1] - y0) / cell).astype(np.int64), ny - 1)
        out = np.full(len(pts), np.nan)
        idx = np.flatnonzero(inside)
        if idx.size:
            cand = table[iy[idx] * nx + ix[idx]]  # (P, w)
            valid = cand >= 0
            tri = self._tri[np.where(valid, cand, 0)]  # (P, w, 3, 3)
            p = pts[idx][:, None, :]
            a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
            e1, e2, r = b[..., :2] - a[..., :2], c[..., :2] - a[..., :2], p - a[..., :2]
            det = e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]
            good = valid & (np.abs(det) > 1e-14)
            inv = 1.0 / np.where(good, det, 1.0)
            s = (r[..., 0] * e2[..., 1] - r[..., 1] * e2[..., 0]) * inv
            t = (e1[..., 0] * r[..., 1] - e1[..., 1] * r[..., 0]) * inv
            tol = 1e-12
            hit = good & (s >= -tol) & (t >= -tol) & (s + t <= 1.0 + tol)
            z = a[..., 2] + s * (b[..., 2] - a[..., 2]) + t * (c[..., 2] - a[..., 2])
            z = np.where(hit, z, -np.inf)
            best = z.max(axis=1)
            out[idx] = np.where(np.isfinite(best), best, np.nan)
        return out.reshape(shape)

    def line_of_sight(self, a: ArrayLike, b: ArrayLike, margin: float = 0.0,
                      chunk: int = 256) -> NDArray[np.bool_]:
        """True where the segment ``a[i] -> b[i]`` does not meet the terrain.

        The segment is stopped ``margin`` metres short of ``b`` so that a target lying on
        the surface (a landmark on the ground) does not occlude itself.

        Parameters
        ----------
        a, b : (S, 3) arrays (or (3,), broadcast).
        margin : float, metres.
        chunk : segments tested per batch against the bounding-box-culled triangles.

        Returns
        -------
        (S,) bool array.
        """
        a = np.atleast_2d(np.asarray(a, dtype=np.float64))
        b = np.atleast_2d(np.asarray(b, dtype=np.float64))
        a, b = np.broadcast_arrays(a, b)
        d = b - a
        length = np.linalg.norm(d, axis=1)
        keep = np.clip(1.0 - margin / np.where(length > 0, length, 1.0), 0.0, 1.0)
        b = a + d * keep[:, None]
        visible = np.ones(len(a), dtype=bool)
        slo, shi = np.minimum(a, b), np.maximum(a, b)
        for s0 in range(0, len(a), chunk):
            sl = slice(s0, s0 + chunk)
            overlap = np.all((slo[sl, None, :] <= self._hi[None]) &
                             (shi[sl, None, :] >= self._lo[None]), axis=2)
            si, ti = np.nonzero(overlap)
            if si.size == 0:
                continue
            hit = segments_hit_triangles(a[sl][si], b[sl][si], self._tri[ti])
            blocked = np.zeros(overlap.shape[0], dtype=bool)
            blocked[si[hit]] = True
            visible[sl] &= ~blocked
        return visible


def hills_height(X: ArrayLike, Y: ArrayLike, centres: ArrayLike, amplitude: float,
                 width: float) -> Array:
    r""":math:`A \sum_i \exp(-\lVert (x, y) - c_i\rVert^2 / 2w^2)` (no base height)."""
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    c = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    Z = np.zeros(np.broadcast_shapes(X.shape, Y.shape))
    for cx, cy in c:
        Z = Z + np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2.0 * width * width))
    return amplitude * Z
