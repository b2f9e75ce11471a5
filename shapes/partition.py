"""Exact 2-D convex partition of a simple polygon (Hertel-Mehlhorn).

MuJoCo collides a mesh geom as its convex hull, so a concave outline (moon,
pentagram) must be handed over as convex pieces whose union is the outline;
otherwise the finger would ride over the hull and never drop into the notch.

Method: a constrained Delaunay triangulation (shapely >= 2.1) of the outline,
then Hertel-Mehlhorn: remove each triangulation diagonal whose removal keeps
both neighbouring pieces convex. The pieces use only the outline's own
vertices, so their union is the polygon exactly and they do not overlap; the
piece count is at most four times the optimum.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon

# Relative tolerance for "collinear" (|cross| / |e1||e2|): keeps a merge whose
# two edges are straight continuations of each other.
_COLLINEAR_REL = 1e-9


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _turns(pts: np.ndarray) -> np.ndarray:
    """Normalised cross product at each vertex of a closed ring (k, 2) -> (k,)."""
    prev = np.roll(pts, 1, axis=0)
    nxt = np.roll(pts, -1, axis=0)
    e1, e2 = pts - prev, nxt - pts
    cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    return cross / (np.hypot(*e1.T) * np.hypot(*e2.T))


def is_convex_ccw(pts: np.ndarray) -> bool:
    """True if the ring (k, 2) turns left (or goes straight) at every vertex."""
    return bool(np.all(_turns(pts) >= -_COLLINEAR_REL))


def drop_collinear(pts: np.ndarray) -> np.ndarray:
    """The ring (k, 2) without vertices where it goes straight on."""
    return pts[np.abs(_turns(pts)) > _COLLINEAR_REL]


def convex_partition(polygon: Polygon) -> list[np.ndarray]:
    """Split a simple polygon (no holes) into convex pieces.

    Returns a list of counter-clockwise vertex arrays (k_i, 2), each a convex
    polygon without collinear vertices; their union is ``polygon`` and their
    interiors are disjoint.
    """
    if not isinstance(polygon, Polygon) or polygon.is_empty or not polygon.is_valid:
        raise ValueError(f"polygon must be a valid, non-empty shapely Polygon; got {polygon!r}")
    if polygon.interiors:
        raise ValueError("polygon must have no holes")
    ring = np.asarray(polygon.exterior.coords)[:-1]
    if not polygon.exterior.is_ccw:
        ring = ring[::-1]
    if is_convex_ccw(ring):
        return [drop_collinear(ring)]

    index = {tuple(p): i for i, p in enumerate(ring)}
    pieces: list[list[int] | None] = []
    for tri in shapely.constrained_delaunay_triangles(polygon).geoms:
        corners = [_vertex_index(p, ring, index) for p in np.asarray(tri.exterior.coords)[:3]]
        if _cross(*ring[corners]) < 0:
            corners.reverse()
        pieces.append(corners)

    owner = {}  # directed edge (a, b) -> index of the piece that has it
    for k, cyc in enumerate(pieces):
        for a, b in zip(cyc, cyc[1:] + cyc[:1], strict=True):
            owner[(a, b)] = k
    # Interior diagonals, longest first: removing long ones first gives fewer slivers.
    diagonals = sorted(
        ((a, b) for (a, b) in owner if a < b and (b, a) in owner),
        key=lambda e: -float(np.hypot(*(ring[e[0]] - ring[e[1]]))),
    )
    for a, b in diagonals:
        p, q = owner[(a, b)], owner[(b, a)]
        merged = _merge(pieces[p], pieces[q], a, b)
        if not is_convex_ccw(ring[merged]):
            continue
        pieces[p], pieces[q] = merged, None
        del owner[(a, b)], owner[(b, a)]
        for u, v in zip(merged, merged[1:] + merged[:1], strict=True):
            owner[(u, v)] = p
    return [drop_collinear(ring[cyc]) for cyc in pieces if cyc is not None]


def _vertex_index(p: np.ndarray, ring: np.ndarray, index: dict) -> int:
    i = index.get(tuple(p))
    if i is None:  # the triangulation rounded a coordinate: take the nearest vertex
        i = int(np.argmin(np.hypot(*(ring - p).T)))
        if np.hypot(*(ring[i] - p)) > 1e-9 * np.ptp(ring).max():
            raise RuntimeError("triangulation introduced a new vertex")
    return i


def _merge(p: list[int], q: list[int], a: int, b: int) -> list[int]:
    """Join piece p (with edge a->b) and piece q (with edge b->a) across that edge."""
    i = p.index(b)
    p_rot = p[i:] + p[:i]  # starts at b, ends at a
    j = q.index(a)
    q_rot = q[j:] + q[:j]  # starts at a, ends at b
    return p_rot + q_rot[1:-1]
