"""Outlines from the user's sources: SVG and DXF files and Python functions returning
build123d faces, each polygonised within a chord tolerance.

Each reader returns the outline's vertices ``(k, 2)`` in metres, in the source's own
position (``Specimen.from_outline`` orients and centres them), and whether it had curved
sides. A bad source raises ``ValueError`` with the rule alone (``"the SVG path 'x' is
open ..."``); the experiment loader puts the file and the entry in front.

- SVG: build123d's importer (``build123d.import_svg``). A user unit is a millimetre; a
  file whose ``width``/``height`` carry physical units (``mm``, ``cm``, ``in``) is
  scaled by them, as the importer does. SVG's y axis points down; the importer flips
  it, so the outline appears as drawn.
- DXF: build123d reads no DXF, so ezdxf (the library build123d writes DXF with) reads
  it: closed polylines (bulges included), circles, ellipses and closed splines, or a
  loop of lines, arcs, splines and open polylines joined end to end. Units from the
  header's ``$INSUNITS``; unitless drawings are taken as millimetres.
- A function (``file.py:function`` or ``package.module:function``) returns a build123d
  ``Face``, ``Sketch`` or closed ``Wire`` in the plane z = 0, in millimetres.

Curves are polygonised with vertices on the curve and chord error at most the
tolerance (``SPECIMEN.curve_tolerance_m``, as the built-ins): OpenCASCADE's uniform
deflection for build123d edges, ezdxf's flattening of each DXF line and curve (arcs
and circles by their sagitta, ellipses and splines adaptively).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tactile_synth import plugins
from tactile_synth.plugins import one_line

#: Largest gap between an outline's ends, or between two DXF edges, still taken as
#: joined (0.1 um: far below any feature, far above rounding in a file's coordinates).
GAP_TOL_M = 1e-7
#: Largest |z| of a face taken as lying in the plane z = 0.
PLANE_TOL_M = 1e-9


def _gap_mm(a: np.ndarray, b: np.ndarray, unit_m: float) -> str:
    return f"{float(np.hypot(*(a - b))) * unit_m * 1e3:.3g} mm"


# --- build123d shapes ---------------------------------------------------------------


def build123d_outline(shape: object, tolerance_m: float, unit_m: float = 1e-3):
    """``(vertices (k, 2) in metres, curved)`` of a build123d ``Face``, ``Sketch`` with
    one face, or closed ``Wire`` (or ``BuildSketch``) lying in the plane z = 0, whose
    numbers are in units of ``unit_m`` metres; ``ValueError`` naming the rule otherwise."""
    import build123d as bd

    if isinstance(shape, bd.BuildSketch):
        shape = shape.sketch
    if not isinstance(shape, bd.Shape):
        raise ValueError(f"got {type(shape).__name__}, not a build123d Face, Sketch or closed Wire")
    faces = shape.faces()
    if len(faces) > 1:
        raise ValueError(f"the shape holds {len(faces)} faces; a specimen is one outline")
    if faces:
        face = faces[0]
        holes = len(face.inner_wires())
        if holes:
            raise ValueError(
                f"the outline has {holes} hole(s); a specimen is one outline without holes "
                "(the raised solid must be one piece the finger rides over)"
            )
        wire = face.outer_wire()
    else:
        wires = shape.wires()
        if len(wires) != 1:
            raise ValueError(
                f"the shape holds {len(wires)} wires and no face; give one closed outline"
            )
        wire = wires[0]
    bb = wire.bounding_box()
    if max(abs(bb.min.Z), abs(bb.max.Z)) * unit_m > PLANE_TOL_M:
        raise ValueError(
            f"the outline leaves the plane z = 0 (z from {bb.min.Z:g} to {bb.max.Z:g}); "
            "draw it in the XY plane"
        )
    return _wire_ring(wire, tolerance_m / unit_m, unit_m)


def _wire_ring(wire: Any, tolerance: float, unit_m: float) -> tuple[np.ndarray, bool]:
    """Walk a wire's edges end to end: lines by their ends, curves polygonised.

    Edges are joined by their coordinates, not in the order the wire lists them (which
    need not follow the outline, e.g. where it crosses itself)."""
    import build123d as bd

    parts, curved = [], False
    for edge in wire.edges():
        if edge.geom_type == bd.GeomType.LINE:
            ends = (edge @ 0, edge @ 1)
            parts.append(np.array([(v.X, v.Y) for v in ends]))
        else:
            curved = True
            try:
                points = edge.positions(deflection=tolerance)
            except (RuntimeError, ValueError) as exc:  # OpenCASCADE could not sample it
                raise ValueError(
                    f"a {edge.geom_type.name.lower()} edge cannot be polygonised: {one_line(exc)}"
                ) from None
            parts.append(np.array([(v.X, v.Y) for v in points]))
    loops, open_ends = _loops(parts, GAP_TOL_M / unit_m)
    if open_ends is not None:
        raise ValueError(f"the outline is open: its ends are {_gap_mm(*open_ends, unit_m)} apart")
    if len(loops) != 1:
        raise ValueError(f"the outline is {len(loops)} separate loops; a specimen is one")
    return loops[0] * unit_m, curved


def _next_part(todo: list[np.ndarray], end: np.ndarray, gap: float) -> tuple[int, bool] | None:
    """(index, forward) of the first part that starts (forward) or ends at ``end``."""
    for i, part in enumerate(todo):
        if np.hypot(*(part[0] - end)) <= gap:
            return i, True
        if np.hypot(*(part[-1] - end)) <= gap:
            return i, False
    return None


# --- SVG ------------------------------------------------------------------------------


def svg_outline(path: Path, path_id: str | None, tolerance_m: float) -> tuple[np.ndarray, bool]:
    """The one closed outline of an SVG file, or the element with id ``path_id``."""
    _check_file(path, "SVG")  # before the slow import
    import build123d as bd

    try:
        objects = bd.import_svg(path, align=None)
    except Exception as exc:  # the importer raises what its XML and path parsers raise
        raise ValueError(f"cannot read the SVG file {path}: {one_line(exc)}") from None
    if path_id is not None:
        chosen = [o for o in objects if o.label == path_id]
        if not chosen:
            ids = sorted({o.label for o in objects if o.label})
            raise ValueError(
                f"the SVG file {path} has no element with id {path_id!r}"
                + (f" (ids: {', '.join(ids)})" if ids else " (its elements have no ids)")
            )
        if len(chosen) > 1:
            raise ValueError(
                f"the SVG element {path_id!r} holds {len(chosen)} outlines; "
                "a specimen is one outline"
            )
        what = f"the SVG element {path_id!r}"
    else:
        chosen = [o for o in objects if isinstance(o, bd.Face) or o.is_closed]
        if len(chosen) != 1:
            named = ", ".join(o.label or "(no id)" for o in chosen)
            if not chosen:
                open_ = ", ".join(o.label or "(no id)" for o in objects)
                extra = f"; open paths: {open_}" if objects else ""
                raise ValueError(f"the SVG file {path} holds no closed outline{extra}")
            raise ValueError(
                f"the SVG file {path} holds {len(chosen)} closed outlines ({named}); "
                "choose one with svg_path_id"
            )
        what = f"the SVG path {chosen[0].label!r}" if chosen[0].label else "the SVG path"
    try:
        return build123d_outline(chosen[0], tolerance_m)
    except ValueError as exc:
        raise ValueError(f"{what}: {exc}") from None


# --- DXF ------------------------------------------------------------------------------

#: DXF entities that can form an outline; every other entity (text, dimensions, hatches,
#: points, block references) is ignored.
DXF_CURVES = ("LWPOLYLINE", "POLYLINE", "LINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE")


def dxf_outline(path: Path, layer: str | None, tolerance_m: float) -> tuple[np.ndarray, bool]:
    """The one closed outline of a DXF file's model space (on ``layer`` if given)."""
    _check_file(path, "DXF")
    import ezdxf
    from ezdxf import units

    try:
        doc = ezdxf.readfile(path)
    except (OSError, ezdxf.DXFError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read the DXF file {path}: {one_line(exc)}") from None
    insunits = doc.header.get("$INSUNITS", 0)
    if insunits == 0:  # unitless: millimetres, as for SVG user units
        unit_m = 1e-3
    else:
        try:
            unit_m = units.conversion_factor(insunits, units.InsertUnits.Meters)
        except (ValueError, KeyError):
            raise ValueError(
                f"the DXF file {path} has unknown units ($INSUNITS={insunits})"
            ) from None
    entities = [e for e in doc.modelspace() if e.dxftype() in DXF_CURVES]
    if layer is not None:
        layers = sorted({e.dxf.layer for e in entities})
        entities = [e for e in entities if e.dxf.layer.lower() == layer.lower()]
        if not entities:
            raise ValueError(
                f"the DXF file {path} has no lines or curves on layer {layer!r} "
                f"(layers: {', '.join(layers) or 'none'})"
            )
    tolerance = tolerance_m / unit_m
    parts, curved = [], False
    for entity in entities:
        for piece in _dxf_pieces(entity):
            points = _dxf_points(piece, tolerance)
            if np.abs(points[:, 2]).max() * unit_m > PLANE_TOL_M:
                raise ValueError(
                    f"the DXF file {path} has a {piece.dxftype()} outside the plane z = 0"
                )
            parts.append(points[:, :2])
            curved |= piece.dxftype() != "LINE"
    loops, open_ends = _loops(parts, GAP_TOL_M / unit_m)
    if len(loops) != 1:
        if not loops and open_ends is not None:
            raise ValueError(
                f"the outline in the DXF file {path} is open: its ends are "
                f"{_gap_mm(*open_ends, unit_m)} apart"
            )
        found = f"{len(loops)} closed outlines" if loops else "no closed outline"
        raise ValueError(
            f"the DXF file {path} holds {found}; a specimen is one"
            + ("" if layer is not None or not loops else " (choose a layer with dxf_layer)")
        )
    if open_ends is not None:
        raise ValueError(
            f"the DXF file {path} holds lines or curves that close no outline besides its "
            "outline; remove them or put the outline on its own layer (dxf_layer)"
        )
    return loops[0] * unit_m, curved


def _dxf_pieces(entity: Any) -> list:
    """A polyline's segments (lines and arcs), any other entity itself."""
    if entity.dxftype() in ("LWPOLYLINE", "POLYLINE"):
        return list(entity.virtual_entities())
    return [entity]


def _dxf_points(entity: Any, tolerance: float) -> np.ndarray:
    """(k, 3) points in world coordinates along one line or curve, vertices on the curve
    and chords within ``tolerance`` of it (ezdxf's exact flattening of each kind)."""
    kind = entity.dxftype()
    if kind == "LINE":
        points = [entity.dxf.start, entity.dxf.end]
    elif kind in ("ARC", "CIRCLE"):
        points = list(entity.flattening(sagitta=tolerance))
    else:  # ELLIPSE, SPLINE: adaptive, each chord's middle within tolerance of the curve
        points = list(entity.flattening(tolerance))
    return np.array([(p[0], p[1], p[2]) for p in points], dtype=np.float64)


def _loops(parts: list[np.ndarray], gap: float) -> tuple[list[np.ndarray], tuple | None]:
    """Join polylines end to end into closed loops: (the loops, the ends of the first
    chain that does not close, or None)."""
    todo = list(parts)
    loops, open_ends = [], None
    while todo:
        chain = [todo.pop(0)]
        turned = False
        while not _closed(chain, gap):
            found = _next_part(todo, chain[-1][-1], gap)
            if found is None and not turned:  # grow the chain from its other end
                chain = [c[::-1] for c in reversed(chain)]
                turned = True
                continue
            if found is None:
                break
            part = todo.pop(found[0])
            chain.append(part if found[1] else part[::-1])
        ring = np.vstack(chain)
        if _closed(chain, gap):
            loops.append(ring)
        elif open_ends is None:
            open_ends = (ring[0], ring[-1])
    return loops, open_ends


def _closed(chain: list[np.ndarray], gap: float) -> bool:
    """True if the chain ends where it starts and has room for an area."""
    return sum(len(c) for c in chain) > 3 and np.hypot(*(chain[-1][-1] - chain[0][0])) <= gap


# --- Python functions -----------------------------------------------------------------


def function_outline(
    spec: str, kwargs: Mapping[str, Any], base_dir: Path, tolerance_m: float
) -> tuple[np.ndarray, bool]:
    """The outline a user's function returns (a build123d face, in millimetres)."""
    func = import_function(spec, base_dir)
    try:
        result = func(**kwargs)
    except Exception as exc:
        raise ValueError(f"function {spec!r} raised {one_line(exc)}") from None
    try:
        return build123d_outline(result, tolerance_m)
    except ValueError as exc:
        raise ValueError(f"function {spec!r}: {exc}") from None


def import_function(spec: str, base_dir: Path) -> Callable[..., Any]:
    """The function behind ``"file.py:name"`` (a path relative to ``base_dir``) or
    ``"package.module:name"`` (importable from ``sys.path``, else from ``base_dir``),
    loaded by the project's one plug-in loader; any failure is one ``ValueError``."""
    module, sep, attr = spec.rpartition(":")
    if not sep or not module or not all(p.isidentifier() for p in attr.split(".")):
        raise ValueError(
            f"function must be 'file.py:function' or 'package.module:function'; got {spec!r}"
        )
    who = f"function {spec!r}"
    try:
        mod = plugins.import_module(
            spec, module, "function", prefix="specimen", search_dir=base_dir, who=who
        )
    except ValueError:
        raise
    except Exception as exc:  # the user's module raised while it ran
        raise ValueError(f"{who}: importing {module} failed: {one_line(exc)}") from None
    obj: Any = mod
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"{who}: {module} has no attribute {attr!r}")
        obj = getattr(obj, part)
    if not callable(obj):
        raise ValueError(f"{who}: {attr} is not callable")
    return obj


def _check_file(path: Path, kind: str) -> None:
    if not path.is_file():
        raise ValueError(f"the {kind} file {path} does not exist")


def polygon_outline(value: object) -> np.ndarray:
    """``polygon_mm`` (a list of ``[x, y]`` pairs in millimetres) as vertices in metres."""
    if not isinstance(value, list) or len(value) < 3:
        raise ValueError("polygon_mm must be a list of at least 3 [x, y] pairs (mm)")
    for i, pair in enumerate(value, start=1):
        if (
            not isinstance(pair, list)
            or len(pair) != 2
            or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in pair
            )
        ):
            raise ValueError(
                f"polygon_mm vertex {i} must be a pair [x, y] of numbers; got {pair!r}"
            )
    return np.array(value, dtype=np.float64) * 1e-3
