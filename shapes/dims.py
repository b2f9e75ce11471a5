"""Specimen dimensions: one frozen, validated dataclass shared by every shape.

A specimen is a base plate with one raised planar outline on top. The outline
is the part this package builds (``solid``/``mesh``/``convex_pieces``); the
plate is a plain box that the simulator builds from these dimensions.

Frame: x is the sliding direction, y is across it, z is up. The plate's top
surface is z = 0, so the plate occupies z in [-base_thickness_m, 0] and the
raised outline z in [0, height_m]. Both are centred on the origin in x and y.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from tactile_synth.validation import check_positive

# Widest outline relative to ``outline_size_m`` (the ellipse: 18 mm at the 16 mm
# default); used to check that every outline fits on the plate.
MAX_EXTENT_RATIO = 1.125


@dataclass(frozen=True)
class SpecimenDims:
    """Dimensions of a specimen, SI units (metres).

    Attributes:
        outline_size_m: nominal outline size ``s``. Every outline is defined as a
            multiple of ``s`` (see ``shapes.outlines``): circle diameter ``s``,
            regular-polygon circumradius ``s/2``, ... so all 12 shapes have
            comparable size. Their extents along the sliding x axis lie between
            0.875 ``s`` (square) and 1.125 ``s`` (ellipse); 16 mm gives 14-18 mm,
            which a finger at 10 mm/s crosses entry edge to exit edge within the
            paper's 2 s window.
        height_m: height of the raised outline above the plate's top surface.
        base_length_m: plate length along x (the sliding direction).
        base_width_m: plate width along y.
        base_thickness_m: plate thickness (below z = 0).
        curve_tolerance_m: largest chord error allowed when a curved outline is
            approximated by a polygon (convex pieces, meshes, outlines).
    """

    outline_size_m: float = 0.016
    height_m: float = 0.002
    base_length_m: float = 0.060
    base_width_m: float = 0.030
    base_thickness_m: float = 0.003
    curve_tolerance_m: float = 0.02e-3

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            check_positive(name, value, unit="m")
        widest_m = MAX_EXTENT_RATIO * self.outline_size_m
        for name in ("base_length_m", "base_width_m"):
            if getattr(self, name) <= widest_m:
                raise ValueError(
                    f"{name} must exceed the widest outline ({widest_m:g} m = "
                    f"{MAX_EXTENT_RATIO} * outline_size_m); got {getattr(self, name)!r}"
                )
        if self.curve_tolerance_m > self.outline_size_m / 100:
            raise ValueError(
                "curve_tolerance_m must be <= outline_size_m / 100 "
                f"({self.outline_size_m / 100:g} m); got {self.curve_tolerance_m!r}"
            )

    def to_dict(self) -> dict[str, float]:
        """The fields as a JSON-serialisable dict."""
        return asdict(self)


SPECIMEN = SpecimenDims()


def check_dims(dims: object) -> SpecimenDims:
    """Return ``dims`` if it is a ``SpecimenDims``; else raise ``ValueError``."""
    if not isinstance(dims, SpecimenDims):
        raise ValueError(f"dims must be a SpecimenDims; got {type(dims).__name__}")
    return dims
