"""Write specimens to CAD/mesh files (STL, OBJ, STEP)."""

from __future__ import annotations

import os
from pathlib import Path

from shapes.dims import SPECIMEN, SpecimenDims
from shapes.files import new_temp_file
from shapes.outlines import check_specimen
from shapes.specimen import Specimen, SpecimenLike, specimen_name
from tactile_synth.validation import check_choice

FORMATS = ("stl", "obj", "step")
UNITS = {"m": 1.0, "mm": 1000.0}


def export(
    name: SpecimenLike,
    out_dir: str | os.PathLike,
    fmt: str = "stl",
    *,
    unit: str = "m",
    dims: SpecimenDims = SPECIMEN,
) -> Path:
    """Write the raised specimen ``name`` (a built-in shape name or a ``Specimen``) to
    ``out_dir/<name>.<fmt>`` and return the path.

    STL/OBJ hold ``mesh(name)`` scaled to ``unit`` (STL has no unit field: metres by
    default, ``unit="mm"`` for slicers and CAD tools that assume millimetres). STEP
    holds the exact build123d solid at its true size; the file records its own
    length unit (millimetres), so ``unit`` does not apply to it. An existing
    file is replaced atomically, so an interrupted export never leaves a truncated one.
    """
    check_specimen(name)
    check_choice("fmt", fmt, FORMATS)
    check_choice("unit", unit, tuple(UNITS))
    if isinstance(name, Specimen):
        name.check_on_plate(dims)
    stem = specimen_name(name)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{stem}.{fmt}"
    tmp = str(new_temp_file(out, f".{stem}.", f".{fmt}"))
    try:
        if fmt == "step":
            from shapes.cad import export_step

            export_step(name, tmp, dims)
        else:
            from shapes.meshes import mesh

            tm = mesh(name, dims)
            tm.apply_scale(UNITS[unit])
            tm.export(tmp, file_type=fmt)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
