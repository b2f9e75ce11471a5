"""The 12 planar specimens of the reference paper (S1..S12), built with build123d, and
the user's own specimens.

Public API (metres throughout; x is the sliding direction, z up):

- ``SHAPE_NAMES``: the 12 names in the paper's order.
- ``SPECIMEN``: default ``SpecimenDims`` (outline size, raised height, base plate).
- ``Specimen``: a user's outline (vertices in metres, height, source), checked like the
  12 and serialisable to a plain dict (``to_dict``/``from_dict``); ``docs/specimens.md``.
- ``load_specimens(path)``: the ``[[specimen]]`` tables of an experiment file (TOML):
  built-ins by name, user outlines from polygons, SVG, DXF or build123d functions.
- ``outline(name)``: shapely Polygon of the outline, centred on the origin.
- ``analytic_area_m2(name)``: exact area of the outline's definition.
- ``solid(name)``: build123d Part, the outline extruded to z in [0, height_m].
- ``mesh(name)``: watertight trimesh of the solid (cached on disk).
- ``convex_pieces(name)``: non-overlapping convex trimesh prisms whose union is the solid.
- ``is_curved(name)``, ``x_extent_m(name)``: curved sides; length along x.

Each ``name`` is a built-in shape name or a ``Specimen``. Only the raised outline is
built here; the base plate (top at z = 0) is a box the simulator makes from
``SPECIMEN``. build123d and trimesh are imported lazily, so importing ``shapes`` is
cheap, and reading a cached mesh never imports build123d. Every function takes an
optional ``dims`` (default ``SPECIMEN``); an unknown name raises ``ValueError`` listing
the valid names.
"""

import tactile_synth.threads  # noqa: F401  (first: sizes thread pools before numpy/torch load)
from shapes.cad import solid
from shapes.dims import SPECIMEN, SpecimenDims
from shapes.experiment import load_specimens, parse_specimens
from shapes.meshes import convex_pieces, mesh
from shapes.outlines import SHAPE_NAMES, analytic_area_m2, is_curved, outline, x_extent_m
from shapes.specimen import (
    Specimen,
    SpecimenError,
    SpecimenLike,
    specimen_from_dict,
    specimen_name,
    specimen_to_dict,
    specimens_from_json,
    specimens_to_json,
)

__all__ = [
    "SHAPE_NAMES",
    "SPECIMEN",
    "Specimen",
    "SpecimenDims",
    "SpecimenError",
    "SpecimenLike",
    "analytic_area_m2",
    "convex_pieces",
    "is_curved",
    "load_specimens",
    "mesh",
    "outline",
    "parse_specimens",
    "solid",
    "specimen_from_dict",
    "specimen_name",
    "specimen_to_dict",
    "specimens_from_json",
    "specimens_to_json",
    "x_extent_m",
]
