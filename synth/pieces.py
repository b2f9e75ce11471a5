"""Contacts of a specimen made of several convex pieces: one per region of its surface.

MuJoCo collides a mesh as its convex hull, so the raised outline of a concave shape (the
moon, the pentagram) is several convex prisms side by side
(:func:`shapes.convex_pieces`). Each prism the skin overlaps makes a soft contact of its
own, and contacts at the same depth add their forces: where the skin's patch spans
several pieces of one flat top, the top acts as several times stiffer than the skin's
fitted Hertz contact (on the moon's horns, three to five slices: the pad sinks less than
half as deep under the same load), and every seam between pieces acts as an edge of its
own. The real specimen is one solid; its top face is one plane.

Every surface update (:mod:`synth.closed_loop`), :class:`PieceContacts` lets the skin
collide, per trial, only with the pieces that carry a distinct region of the surface it
can touch, chosen from the simulated centre ``c`` of the skin's sphere:

- ``c`` above the top face (inside the outline): the piece under ``c``;
- otherwise: the pieces owning the local minima of the horizontal distance from ``c``
  along the outline that lie within the pad's radius (the wall or corner the skin leans
  on; two where it touches both sides of a notch).

A seam between pieces is never such a minimum, so it makes no contact of its own. The
choice is held over an update period (tens of micrometres of travel); switching at a
seam exchanges two coplanar faces at the same depth, so the contact force does not jump.
Single-piece outlines need none of this (:func:`piece_contacts` returns ``None``).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import shapely

import shapes
from shapes import SpecimenLike
from shapes.partition import convex_partition

from . import kernels


@dataclass(frozen=True)
class Outline:
    """A multi-piece outline as arrays.

    normals, offsets: ``(m, 2)``, ``(m,)`` the pieces' edges as half-planes (inside:
    ``normal . p <= offset``), grouped by piece; starts: ``(n,)`` index of each piece's
    first edge. seg_a, seg_b: ``(s, 2)`` the outline's segments (counter-clockwise);
    seg_piece: ``(s,)`` the piece owning each segment.
    """

    normals: np.ndarray
    offsets: np.ndarray
    starts: np.ndarray
    seg_a: np.ndarray
    seg_b: np.ndarray
    seg_piece: np.ndarray

    @property
    def n_pieces(self) -> int:
        return int(self.starts.size)

    @functools.cached_property
    def edges(self) -> np.ndarray:
        """``(s, 2)`` each segment's vector, ``seg_b - seg_a``."""
        return self.seg_b - self.seg_a

    @functools.cached_property
    def edge_sq(self) -> np.ndarray:
        """``(s,)`` each segment's squared length."""
        return (self.edges * self.edges).sum(axis=1)

    @functools.cached_property
    def previous(self) -> np.ndarray:
        """``(s,)`` index of the segment before each one along the outline."""
        return np.roll(np.arange(self.seg_a.shape[0]), 1)


@functools.lru_cache(maxsize=16)
def outline_pieces(shape: SpecimenLike) -> Outline | None:
    """The outline of ``shape`` (a built-in name or a ``Specimen``) with its convex pieces
    (the order of the scene's ``piece<i>`` geoms), or ``None`` for a single piece."""
    poly = shapes.outline(shape)
    pieces = convex_partition(poly)
    if len(pieces) < 2:
        return None
    normals, offsets, starts = [], [], []
    edges = 0
    for ring in pieces:  # counter-clockwise: the inside is left of every edge
        starts.append(edges)
        edges += len(ring)
        nxt = np.roll(ring, -1, axis=0)
        edge = nxt - ring
        outward = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
        outward /= np.linalg.norm(outward, axis=1, keepdims=True)
        normals.append(outward)
        offsets.append((outward * ring).sum(axis=1))
    ring = np.asarray(poly.exterior.coords)[:-1]
    if not poly.exterior.is_ccw:
        ring = ring[::-1]
    seg_b = np.roll(ring, -1, axis=0)
    middles = shapely.points((ring + seg_b) / 2)
    polys = [shapely.Polygon(r) for r in pieces]
    owner = np.array([int(np.argmin([shapely.distance(m, p) for p in polys])) for m in middles])
    return Outline(
        normals=np.concatenate(normals),
        offsets=np.concatenate(offsets),
        starts=np.asarray(starts, dtype=np.intp),
        seg_a=ring,
        seg_b=seg_b,
        seg_piece=owner,
    )


def touchable(outline: Outline, centre: np.ndarray, reach_m: float) -> np.ndarray:
    """Boolean ``(b, n_pieces)``: the pieces carrying a distinct region of the surface
    that a skin sphere centred above ``centre`` ``(b, 2)`` can touch (module docstring)."""
    # Inside a piece: every edge's half-plane holds (the largest excess is <= 0). On a seam
    # the centre is inside both neighbours; the first of them is chosen. Outside (the
    # other trials): local minima of the distance along the outline, within reach: per
    # segment, the foot of the perpendicular at parameter t along it, clamped to it; a
    # segment's interior, or a vertex where both sides end (kernels.touchable, compiled:
    # the closed loop asks every period).
    out = np.zeros((centre.shape[0], outline.n_pieces), dtype=bool)
    kernels.touchable(
        outline.normals,
        outline.offsets,
        outline.starts,
        centre,
        outline.seg_a,
        outline.edges,
        outline.edge_sq,
        outline.previous,
        outline.seg_piece,
        reach_m,
        out,
    )
    return out


class PieceContacts:
    """Keeps each trial model's piece collisions to :func:`touchable`'s choice.

    models: one per trial (their ``geom_contype`` / ``geom_conaffinity`` are changed);
    geoms: the piece geom ids in outline order.
    """

    def __init__(
        self,
        outline: Outline,
        models: Sequence[mujoco.MjModel],
        geoms: np.ndarray,
        reach_m: float,
    ) -> None:
        self.outline = outline
        self.models = list(models)
        self.geoms = np.asarray(geoms, dtype=np.intp)
        self.reach_m = reach_m
        self.types = [int(m.geom_contype[self.geoms[0]]) for m in self.models]
        self.affinities = [int(m.geom_conaffinity[self.geoms[0]]) for m in self.models]
        self.enabled = np.ones((len(self.models), outline.n_pieces), dtype=bool)

    def update(self, centre: np.ndarray) -> None:
        """Enable the pieces :func:`touchable` chooses for skin centres ``(b, 2)``."""
        want = touchable(self.outline, centre, self.reach_m)
        for trial, piece in zip(*np.nonzero(want != self.enabled), strict=True):
            model, geom, on = self.models[trial], self.geoms[piece], want[trial, piece]
            model.geom_contype[geom] = self.types[trial] if on else 0
            model.geom_conaffinity[geom] = self.affinities[trial] if on else 0
        self.enabled = want


def piece_contacts(
    shape: SpecimenLike, models: Sequence[mujoco.MjModel], reach_m: float
) -> PieceContacts | None:
    """The piece selector of a batch of trial models of ``shape`` (``None`` when its
    outline is one convex piece, or the models have no raised outline)."""
    outline = outline_pieces(shape)
    base = models[0]
    geoms = [
        mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_GEOM, f"piece{i}") for i in range(base.nmesh)
    ]
    if outline is None or len(geoms) != outline.n_pieces or min(geoms, default=-1) < 0:
        return None
    return PieceContacts(outline, models, np.asarray(geoms), reach_m)
