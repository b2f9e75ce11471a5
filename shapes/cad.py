"""build123d solids of the raised outlines (imported lazily: build123d costs seconds).

The solids are built from the same documented dimensions as ``shapes.outlines``
but with exact curves (build123d circles, ellipses, booleans), so the solid is
the reference the polygonised outlines and convex pieces are checked against.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from shapes import outlines as ol
from shapes.dims import SPECIMEN, SpecimenDims, check_dims
from shapes.specimen import Specimen, SpecimenLike, specimen_name

if TYPE_CHECKING:
    import build123d

# Angular deflection for tessellation (rad): loose, so the chord error bound decides.
_ANGULAR_TOLERANCE_RAD = 0.5


def sketch(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> build123d.Sketch:
    """The outline as a build123d face on the plane z = 0, metres, exact curves; for a
    ``Specimen``, its polygon (a curved source as polygonised when it was loaded)."""
    import build123d as bd

    ol.check_specimen(name)
    check_dims(dims)
    if isinstance(name, Specimen):
        name.check_on_plate(dims)
        return bd.Sketch() + bd.Polygon(*name.vertices_m, align=None)
    s = dims.outline_size_m
    r = s / 2
    if name == "circle":
        return bd.Sketch() + bd.Circle(r)
    if name == "ellipse":
        a, b = (k * s for k in ol.ELLIPSE_SEMI_AXES)
        return bd.Sketch() + bd.Ellipse(a, b)
    if name == "semicircle":
        disc = bd.Pos(0, -r / 2) * bd.Circle(r)
        keep = bd.Pos(0, r / 2) * bd.Rectangle(4 * r, 2 * r)  # everything above y = -r/2
        return disc & keep
    if name == "moon":
        return bd.Circle(r) - bd.Pos(0, ol.MOON_OFFSET * s) * bd.Circle(r)
    # Polygonal outlines: exact vertices from the shared definition.
    pts = [tuple(p) for p in ol.outline_vertices(name, dims)]
    return bd.Sketch() + bd.Polygon(*pts, align=None)


def solid(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> build123d.Part:
    """The raised specimen: the outline extruded from z = 0 to ``dims.height_m`` (metres;
    a ``Specimen`` to its own ``height_m``).

    The base plate is not part of it (see ``shapes.dims``).
    """
    import build123d as bd

    height = name.height_m if isinstance(name, Specimen) else dims.height_m
    part = bd.extrude(sketch(name, dims), amount=height)
    if not part.is_valid:
        raise RuntimeError(f"build123d produced an invalid solid for {specimen_name(name)}")
    return part


def tessellate(part: build123d.Part, tolerance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a solid: vertices (n, 3) float64 metres and faces (m, 3) int64,
    with chord error <= tolerance_m."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh

    # build123d's own meshing takes the deflection as relative to each edge's size;
    # mesh first with an absolute chord error (serial, for reproducible output), which
    # tessellate() then reuses because it already meets the tolerance.
    BRepMesh_IncrementalMesh(part.wrapped, tolerance_m, False, _ANGULAR_TOLERANCE_RAD, False)
    verts, tris = part.tessellate(tolerance_m, _ANGULAR_TOLERANCE_RAD)
    vertices = np.array([(v.X, v.Y, v.Z) for v in verts], dtype=np.float64)
    faces = np.array(tris, dtype=np.int64).reshape(-1, 3)
    return vertices, faces


def export_step(name: SpecimenLike, path: str, dims: SpecimenDims = SPECIMEN) -> None:
    """Write the exact solid as a STEP file at its true physical size.

    ``unit=Unit.M`` tells build123d that the model's numbers are metres; the
    file itself is written in millimetres (checked: a 16 mm outline appears as
    coordinates of about 8 with ``SI_UNIT(.MILLI.,.METRE.)``).
    """
    import build123d as bd

    if not bd.export_step(solid(name, dims), path, unit=bd.Unit.M):
        raise RuntimeError(f"build123d could not write STEP file {path}")


def area_and_volume(part: build123d.Part) -> tuple[float, float]:
    """(area of the top face in m^2, volume in m^3) of an extruded solid."""
    top = max(part.faces(), key=lambda f: f.center().Z)
    return float(top.area), float(part.volume)
