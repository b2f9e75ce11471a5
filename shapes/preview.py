"""A labelled grid of outlines (PNG), so a user can see what is simulated: the 12
built-in shapes, or the specimens an experiment file names."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from shapes.dims import SPECIMEN, SpecimenDims
from shapes.files import new_temp_file
from shapes.outlines import SHAPE_NAMES, check_specimen, outline
from shapes.partition import convex_partition
from shapes.specimen import Specimen, SpecimenLike

#: Columns of the grid.
COLUMNS = 4


def preview(
    out: str | os.PathLike,
    *,
    specimens: Sequence[SpecimenLike] | None = None,
    title: str | None = None,
    dims: SpecimenDims = SPECIMEN,
    dpi: int = 120,
) -> Path:
    """Draw every outline (mm, same scale, x = sliding direction) with its convex pieces
    dashed, and write the figure to ``out`` (PNG). Returns the path.

    ``specimens``: built-in names and ``Specimen`` objects to draw (default: the 12
    built-ins); ``title``: the figure's title (a default names what is drawn).
    """
    import matplotlib

    matplotlib.use("Agg")  # file output only: never needs a display
    import matplotlib.pyplot as plt

    path = Path(out)
    if path.suffix.lower() != ".png":
        raise ValueError(f"out must be a .png path; got {str(out)!r}")
    shapes_ = SHAPE_NAMES if specimens is None else tuple(check_specimen(s) for s in specimens)
    if not shapes_:
        raise ValueError("specimens must name at least one specimen")
    polys = [outline(s, dims) for s in shapes_]  # checks every specimen before drawing
    half_mm = 0.6 * dims.outline_size_m * 1e3  # widest outline is 1.125 s: 1.2 s box fits
    if specimens is not None:
        reach = max(float(np.abs(p.bounds).max()) for p in polys) * 1e3
        user = any(isinstance(s, Specimen) for s in shapes_)
        half_mm = max(1.07 * reach, 0.0 if user else half_mm)
    cols = min(COLUMNS, len(shapes_))
    rows = math.ceil(len(shapes_) / cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(3 * cols, 9.4 / 3 * rows), sharex=True, sharey=True, squeeze=False
    )
    for shape, poly, ax in zip(shapes_, polys, axes.flat, strict=False):
        _draw(ax, shape, poly, dims)
        ax.set_xlim(-half_mm, half_mm)
        ax.set_ylim(-half_mm, half_mm)
    for ax in axes.flat[len(shapes_) :]:
        ax.set_visible(False)
    for c in range(cols):  # the lowest drawn panel of each column
        col = [axes[r, c] for r in range(rows) if r * cols + c < len(shapes_)]
        col[-1].set_xlabel("x (mm), sliding direction →")
        col[-1].xaxis.set_tick_params(labelbottom=True)
    for ax in axes[:, 0]:
        ax.set_ylabel("y (mm)")
    if title is None:
        title = (
            f"The 12 raised outlines (height {dims.height_m * 1e3:g} mm)"
            if specimens is None
            else f"{len(shapes_)} specimens"
        )
    fig.suptitle(f"{title}; dotted red: centre line y = 0")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = new_temp_file(path.parent, f".{path.stem}.", ".png")
    try:
        fig.savefig(tmp, dpi=dpi)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    finally:
        plt.close(fig)
    return path


def _draw(ax, shape: SpecimenLike, poly, dims: SpecimenDims) -> None:
    ring = np.asarray(poly.exterior.coords) * 1e3
    ax.fill(ring[:, 0], ring[:, 1], color="#c9d6e8", zorder=1)
    pieces = convex_partition(poly)
    if len(pieces) > 1:
        for piece in pieces:
            closed = np.vstack([piece, piece[:1]]) * 1e3
            ax.plot(closed[:, 0], closed[:, 1], color="#7a8ca5", lw=0.6, ls="--", zorder=2)
    ax.plot(ring[:, 0], ring[:, 1], color="#1f3b66", lw=1.5, zorder=3)
    ax.axhline(0, color="#b03a2e", lw=0.8, ls=":", zorder=0)
    x0, _, x1, _ = poly.bounds
    extent = f"({(x1 - x0) * 1e3:.1f} mm along x)"
    if isinstance(shape, Specimen):
        ax.set_title(f"{shape.name}  {extent}", fontsize=10)
        note = shape.source if len(shape.source) <= 40 else shape.source[:39] + "…"
        if shape.height_m != dims.height_m:
            note += f"\n{shape.height_m * 1e3:g} mm high"
        ax.text(0.02, 0.97, note, transform=ax.transAxes, fontsize=7, va="top")
    else:
        ax.set_title(f"S{SHAPE_NAMES.index(shape) + 1} {shape}  {extent}", fontsize=10)
    if len(pieces) > 1:
        ax.text(0.02, 0.03, f"{len(pieces)} convex pieces", transform=ax.transAxes, fontsize=8)
    ax.set_aspect("equal")
    ax.grid(True, lw=0.3, alpha=0.5)
