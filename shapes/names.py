"""The names of the paper's 12 built-in shapes (S1..S12), in the paper's order, and their
check: the one module every other module of the package may import."""

from __future__ import annotations

from tactile_synth.validation import check_choice

SHAPE_NAMES: tuple[str, ...] = (
    "circle",
    "ellipse",
    "semicircle",
    "hexagon",
    "moon",
    "parallelogram",
    "pentagon",
    "pentagram",
    "rhombus",
    "square",
    "trapezoid",
    "triangle",
)


def check_shape(name: object) -> str:
    """Return ``name`` if it is one of ``SHAPE_NAMES``; else raise ``ValueError`` listing them."""
    return check_choice("shape", name, SHAPE_NAMES)
