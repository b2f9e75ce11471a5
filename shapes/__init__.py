"""The 12 planar specimens of the reference paper (S1..S12), built with build123d.

Public API (metres throughout; x is the sliding direction, z up):

- ``SHAPE_NAMES``: the 12 names in the paper's order.
- ``SPECIMEN``: default ``SpecimenDims`` (outline size, raised height, base plate).
- ``outline(name)``: shapely Polygon of the outline, centred on the origin.
- ``analytic_area_m2(name)``: exact area of the outline's definition.
- ``solid(name)``: build123d Part, the outline extruded to z in [0, height_m].
- ``mesh(name)``: watertight trimesh of the solid (cached on disk).
- ``convex_pieces(name)``: non-overlapping convex trimesh prisms whose union is the solid.

Only the raised outline is built here; the base plate (top at z = 0) is a box
the simulator makes from ``SPECIMEN``. build123d and trimesh are imported
lazily, so importing ``shapes`` is cheap, and reading a cached mesh never
imports build123d. Every function takes an optional ``dims`` (default
``SPECIMEN``); an unknown name raises ``ValueError`` listing the valid names.
"""

import tactile_synth.threads  # noqa: F401  (first: sizes thread pools before numpy/torch load)
from shapes.cad import solid
from shapes.dims import SPECIMEN, SpecimenDims
from shapes.meshes import convex_pieces, mesh
from shapes.outlines import SHAPE_NAMES, analytic_area_m2, is_curved, outline

__all__ = [
    "SHAPE_NAMES",
    "SPECIMEN",
    "SpecimenDims",
    "analytic_area_m2",
    "convex_pieces",
    "is_curved",
    "mesh",
    "outline",
    "solid",
]
