"""Specimen outlines made in code with build123d (millimetres, in the XY plane).

``experiment.toml`` names them as ``function = "my_shapes.py:<name>"``, with its
``kwargs`` passed as keyword arguments. Each returns a build123d Sketch with one face.
"""

import build123d as bd


def rounded_slot(length: float = 16.0, width: float = 8.0) -> bd.Sketch:
    """A slot with semicircular ends, ``length`` along x (the sliding direction)."""
    return bd.Sketch() + bd.SlotOverall(length, width)


def gear(teeth: int = 10, root_radius: float = 6.0, tip_radius: float = 8.0) -> bd.Sketch:
    """A spur-gear-like disc: ``teeth`` trapezoidal teeth on a root circle."""
    with bd.BuildSketch() as sketch:
        bd.Circle(root_radius)
        with bd.PolarLocations(0, teeth):
            # One tooth pointing along +x: from inside the root circle out to the tip.
            bd.Polygon(
                (root_radius - 1.0, -1.2),
                (tip_radius, -0.6),
                (tip_radius, 0.6),
                (root_radius - 1.0, 1.2),
                align=None,
            )
    return sketch.sketch
