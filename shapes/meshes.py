"""Triangle meshes of the raised outlines: the whole solid and its convex pieces.

Both are in metres and occupy z in [0, height_m] (the plate top is z = 0; the
plate itself is not included, see ``shapes.dims``).

- ``mesh(name)`` tessellates the build123d solid once and caches it on disk
  (``shapes.cache``); later calls, in any process, read the cache and never
  import build123d.
- ``convex_pieces(name)`` extrudes an exact convex partition of the outline
  (``shapes.partition``): exact for polygonal outlines, within the outline's
  chord tolerance (0.02 mm by default) for curved ones. It needs only shapely
  and numpy and takes milliseconds, so it is computed rather than cached.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from shapes import cache
from shapes.dims import SPECIMEN, SpecimenDims, check_dims
from shapes.outlines import check_specimen, outline
from shapes.partition import convex_partition
from shapes.specimen import Specimen, SpecimenLike, specimen_name

if TYPE_CHECKING:
    import trimesh


def prism_arrays(ring: np.ndarray, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A convex polygon (k, 2), counter-clockwise, extruded from z = 0 to height_m:
    vertices (2k, 3) and outward-facing triangles (4k - 4, 3)."""
    k = len(ring)
    verts = np.vstack(
        [np.column_stack([ring, np.zeros(k)]), np.column_stack([ring, np.full(k, height_m)])]
    )
    fan = np.array([[0, i, i + 1] for i in range(1, k - 1)], dtype=np.int64)
    top = fan + k
    bottom = fan[:, ::-1]
    i = np.arange(k)
    j = (i + 1) % k
    sides = np.vstack([np.column_stack([i, j, j + k]), np.column_stack([i, j + k, i + k])])
    return verts, np.vstack([bottom, top, sides]).astype(np.int64)


def _height_m(name: SpecimenLike, dims: SpecimenDims) -> float:
    return name.height_m if isinstance(name, Specimen) else dims.height_m


@functools.lru_cache(maxsize=64)
def _pieces_arrays(
    name: SpecimenLike, dims: SpecimenDims
) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    height = _height_m(name, dims)
    return tuple(prism_arrays(ring, height) for ring in convex_partition(outline(name, dims)))


def convex_pieces(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> list[trimesh.Trimesh]:
    """Convex, watertight prisms whose union is the raised solid (metres, z in [0, height]).

    The pieces do not overlap. One piece for convex outlines; several for the moon
    and the pentagram (and any concave ``Specimen``), so a collision engine that uses
    each mesh's convex hull still lets the finger drop into the moon's notch and
    between the star's points.
    """
    import trimesh

    check_specimen(name)
    check_dims(dims)
    return [
        trimesh.Trimesh(v.copy(), f.copy(), process=False) for v, f in _pieces_arrays(name, dims)
    ]


def mesh(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> trimesh.Trimesh:
    """Watertight triangle mesh of ``solid(name)`` in metres (z in [0, height]), cached
    on disk; curved sides within ``dims.curve_tolerance_m``. A ``Specimen``'s entry is
    keyed by its geometry hash."""
    import trimesh

    check_specimen(name)
    check_dims(dims)
    if isinstance(name, Specimen):
        name.check_on_plate(dims)
    vertices, faces = _mesh_arrays(name, dims)
    return trimesh.Trimesh(vertices.copy(), faces.copy(), process=False)


@functools.lru_cache(maxsize=64)
def _mesh_arrays(name: SpecimenLike, dims: SpecimenDims) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(name, Specimen):
        path = cache.geometry_entry_path("mesh", name.name, name.geometry_hash)
    else:
        path = cache.entry_path("mesh", name, dims)
    data = cache.load(path)
    if data is not None and _valid_mesh_arrays(data):
        return data["vertices"], data["faces"]
    vertices, faces = build_mesh_arrays(name, dims)
    cache.save(path, {"vertices": vertices, "faces": faces})
    return vertices, faces


def _valid_mesh_arrays(data: dict[str, np.ndarray]) -> bool:
    v, f = data.get("vertices"), data.get("faces")
    return (
        v is not None
        and f is not None
        and v.dtype == np.float64
        and f.dtype == np.int64
        and v.ndim == 2
        and v.shape[1] == 3
        and f.ndim == 2
        and f.shape[1] == 3
        and len(f) > 0
        and int(f.min()) >= 0
        and int(f.max()) < len(v)
    )


def build_mesh_arrays(
    name: SpecimenLike, dims: SpecimenDims = SPECIMEN
) -> tuple[np.ndarray, np.ndarray]:
    """Tessellate the build123d solid (slow: imports build123d). Returns merged,
    outward-oriented vertices (n, 3) float64 and faces (m, 3) int64."""
    import trimesh

    from shapes import cad

    vertices, faces = cad.tessellate(cad.solid(name, dims), dims.curve_tolerance_m)
    tm = trimesh.Trimesh(vertices, faces, process=True)
    if not tm.is_watertight:
        raise RuntimeError(f"tessellation of {specimen_name(name)} is not watertight")
    if tm.volume < 0:
        tm.invert()
    return np.asarray(tm.vertices, dtype=np.float64), np.asarray(tm.faces, dtype=np.int64)
