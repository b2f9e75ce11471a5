"""A labelled grid of the 12 outlines (PNG), so a user can see what is simulated."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from shapes.dims import SPECIMEN, SpecimenDims
from shapes.files import new_temp_file
from shapes.outlines import SHAPE_NAMES, outline
from shapes.partition import convex_partition


def preview(out: str | os.PathLike, *, dims: SpecimenDims = SPECIMEN, dpi: int = 120) -> Path:
    """Draw every outline (mm, same scale, x = sliding direction) with its convex pieces
    dashed, and write the figure to ``out`` (PNG). Returns the path."""
    import matplotlib

    matplotlib.use("Agg")  # file output only: never needs a display
    import matplotlib.pyplot as plt

    path = Path(out)
    if path.suffix.lower() != ".png":
        raise ValueError(f"out must be a .png path; got {str(out)!r}")
    half_mm = 0.6 * dims.outline_size_m * 1e3  # widest outline is 1.125 s: 1.2 s box fits
    fig, axes = plt.subplots(3, 4, figsize=(12, 9.4), sharex=True, sharey=True)
    for i, (name, ax) in enumerate(zip(SHAPE_NAMES, axes.flat, strict=True)):
        poly = outline(name, dims)
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
        ax.set_title(f"S{i + 1} {name}  ({(x1 - x0) * 1e3:.1f} mm along x)", fontsize=10)
        if len(pieces) > 1:
            ax.text(0.02, 0.03, f"{len(pieces)} convex pieces", transform=ax.transAxes, fontsize=8)
        ax.set_aspect("equal")
        ax.set_xlim(-half_mm, half_mm)
        ax.set_ylim(-half_mm, half_mm)
        ax.grid(True, lw=0.3, alpha=0.5)
    for ax in axes[-1]:
        ax.set_xlabel("x (mm), sliding direction →")
    for ax in axes[:, 0]:
        ax.set_ylabel("y (mm)")
    fig.suptitle(
        f"The 12 raised outlines (height {dims.height_m * 1e3:g} mm); dotted red: centre line y = 0"
    )
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
