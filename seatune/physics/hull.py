"""Parametric ship hull: a half-hull surface of stations with rounded bilge and fine ends.

Hull frame: x forward from midship, y to port, z up from the baseline (keel). The generated
surface runs from the keel centreline to the deck edge; `hull_mesh` clips it at a draft and
shifts it so that the calm waterline is z = 0 (the body frame of DESIGN §3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ParametricHull:
    """Monohull with a parallel midbody, superelliptic sections and a rounded bilge.

    length: length between perpendiculars [m]; beam [m]; depth: moulded depth [m];
    bilge_radius [m]; midbody: fraction of the length with constant sections;
    bow_fineness / stern_fineness: exponents of the waterline ending (larger = fuller);
    stern_halfbreadth: half-breadth at the transom as a fraction of B/2 (0 = pointed).
    """

    length: float
    beam: float
    depth: float
    bilge_radius: float = 2.0
    midbody: float = 0.35
    bow_fineness: float = 1.8
    stern_fineness: float = 2.6
    stern_halfbreadth: float = 0.0

    def halfbreadth_scale(self, x: np.ndarray) -> np.ndarray:
        """Half-breadth of the station at x as a fraction of B/2."""
        half = self.length / 2
        m = self.midbody * half
        s = np.clip((np.abs(x) - m) / (half - m), 0.0, 1.0)
        fore = 1.0 - s**self.bow_fineness
        aft = self.stern_halfbreadth + (1.0 - self.stern_halfbreadth) * (1.0 - s**self.stern_fineness)
        return np.where(x >= 0, fore, aft)

    def section_points(self, x: float, n_girth: int) -> np.ndarray:
        """(n_girth, 2) points (y, z) from the keel centreline round the bilge to the deck edge."""
        b = 0.5 * self.beam * float(self.halfbreadth_scale(np.asarray(x)))
        half = self.length / 2
        m = self.midbody * half
        s = float(np.clip((abs(x) - m) / (half - m), 0.0, 1.0))
        # Sections grow deeper in the bilge and more V-like towards the ends.
        h = self.bilge_radius + s**1.5 * (0.8 * self.depth - self.bilge_radius)
        n = 2.0 + (8.0 - 2.0) * (1.0 - s) ** 2
        t = np.linspace(np.pi / 2, 0.0, 200)
        bottom = np.c_[b * np.cos(t) ** (2 / n), h * (1.0 - np.sin(t) ** (2 / n))]
        side = np.c_[[b, b], [h, self.depth]]
        return _resample_by_arclength(np.vstack([bottom, side[1:]]), n_girth + 1)

    def half_surface(self, n_stations: int = 40, n_girth: int = 16) -> tuple[np.ndarray, list[list[int]]]:
        """Vertices (hull frame) and quad faces of the port half, normals pointing out of the hull."""
        u = np.linspace(-1.0, 1.0, n_stations)
        xs = self.length / 2 * (0.6 * u + 0.4 * np.sin(np.pi * u / 2))  # a little finer at the ends
        stations = [self.section_points(x, n_girth) for x in xs]
        npts = stations[0].shape[0]
        vertices = np.array([[x, y, z] for x, sec in zip(xs, stations, strict=True) for y, z in sec])
        faces = []
        for i in range(n_stations - 1):
            for j in range(npts - 1):
                a, b = i * npts + j, (i + 1) * npts + j
                faces.append([a, a + 1, b + 1, b])
        if self.stern_halfbreadth > 0:  # transom: close the aft station towards the centreline
            sec = stations[0]
            centre = len(vertices)
            vertices = np.vstack([vertices, np.c_[np.full(npts, xs[0]), np.zeros(npts), sec[:, 1]]])
            for j in range(npts - 1):
                faces.append([j, centre + j, centre + j + 1, j + 1])
        return vertices, faces


def _resample_by_arclength(points: np.ndarray, n: int) -> np.ndarray:
    """n points equally spaced along the polyline `points`."""
    seg = np.hypot(*np.diff(points, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    target = np.linspace(0.0, s[-1], n)
    return np.c_[np.interp(target, s, points[:, 0]), np.interp(target, s, points[:, 1])]


def hull_mesh(hull: ParametricHull, draft: float, n_stations: int = 40, n_girth: int = 16,
              lid_face_radius: float = 1.8):
    """Capytaine mesh of the immersed hull at `draft`, waterline at z = 0, with xOz symmetry.

    Returns (hull_mesh, lid_mesh).
    """
    import capytaine as cpt

    vertices, faces = hull.half_surface(n_stations, n_girth)
    vertices = vertices - np.array([0.0, 0.0, draft])
    half = cpt.Mesh(vertices=vertices, faces=faces, name="half_hull")
    mesh = cpt.ReflectionSymmetricMesh(half=half, plane="xOz", name="hull")
    immersed = mesh.immersed_part()
    lid = immersed.generate_lid(z=-0.01 * draft, faces_max_radius=lid_face_radius)
    return immersed, lid
