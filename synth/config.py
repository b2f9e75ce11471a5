"""Every parameter of the simulated experiment: one frozen, validated dataclass per physical
component, SI units with the unit in the field name, a one-line rationale per value.

``SynthConfig`` bundles them (plus the materials and the user's specimens) and round-trips
through plain dicts (``to_dict``/``from_dict``) so a dataset stores the exact
configuration that made it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Self

from shapes import SHAPE_NAMES, Specimen, SpecimenLike, specimen_from_dict, specimen_to_dict

from . import params
from .finger_config import Finger
from .materials import MATERIALS, Material
from .motion_config import Motion, Variability
from .sensor_config import PVDF, VACUUM_PERMITTIVITY_F_M, Acquisition, StrainGauge
from .trial import check_name

#: The configuration's names, with the components' dataclasses
#: (:mod:`synth.finger_config`, :mod:`synth.motion_config`, :mod:`synth.sensor_config`)
#: that users reach through this module.
__all__ = [
    "PVDF",
    "VACUUM_PERMITTIVITY_F_M",
    "Acquisition",
    "Finger",
    "Motion",
    "StrainGauge",
    "SynthConfig",
    "Variability",
    "default_synth_config",
    "validate_synth_config",
]


def _default_materials() -> dict[str, Material]:
    return dict(MATERIALS)


@dataclass(frozen=True)
class SynthConfig:
    """The whole simulated experiment. ``SynthConfig()`` is the paper's set-up.

    ``materials``: the materials a trial may name, by name (any set of at least one; the
    default is the paper's three, :data:`synth.materials.MATERIALS`). ``specimens``: the
    user's specimens a trial may name besides the 12 built-in shapes (``shapes.Specimen``
    by name; default none). A trial's ``shape`` resolves to a built-in or one of
    ``specimens`` (:meth:`specimen`), its ``material`` to one of ``materials``
    (:meth:`material`).
    """

    finger: Finger = field(default_factory=Finger)
    motion: Motion = field(default_factory=Motion)
    variability: Variability = field(default_factory=Variability)
    strain_gauge: StrainGauge = field(default_factory=StrainGauge)
    pvdf: PVDF = field(default_factory=PVDF)
    acquisition: Acquisition = field(default_factory=Acquisition)
    materials: dict[str, Material] = field(default_factory=_default_materials)
    specimens: dict[str, Specimen] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name in ("materials", "specimens"):
                continue
            value = getattr(self, f.name)
            if type(value).__name__ != f.type:
                raise ValueError(
                    f"SynthConfig.{f.name} must be a {f.type}; got {type(value).__name__}"
                )
        if not isinstance(self.materials, Mapping) or not self.materials:
            raise ValueError("SynthConfig.materials must define at least one material")
        for name, mat in self.materials.items():
            check_name("SynthConfig.materials key", name)
            if not isinstance(mat, Material) or mat.name != name:
                raise ValueError(
                    f"SynthConfig.materials[{name!r}] must be a Material named {name!r}"
                )
        if not isinstance(self.specimens, Mapping):
            raise ValueError("SynthConfig.specimens must map names to shapes.Specimen")
        for name, spec in self.specimens.items():
            if not isinstance(spec, Specimen) or spec.name != name:
                raise ValueError(
                    f"SynthConfig.specimens[{name!r}] must be a shapes.Specimen named {name!r}"
                )
        if self.finger.skin_solref[0] < 2 * self.motion.timestep_s:
            raise ValueError(
                "Finger.skin_solref's time constant must be >= 2 physics steps "
                f"({2 * self.motion.timestep_s} s); got {self.finger.skin_solref[0]!r}"
            )

    @property
    def specimen_names(self) -> tuple[str, ...]:
        """Every specimen a trial may name: the 12 built-ins (paper order), then
        :attr:`specimens` in their order."""
        return (*SHAPE_NAMES, *self.specimens)

    def specimen(self, name: str) -> SpecimenLike:
        """The built-in shape name or the :class:`shapes.Specimen` that ``name`` names;
        a one-line ``ValueError`` naming the valid ones otherwise."""
        if name in SHAPE_NAMES:
            return name
        found = self.specimens.get(name)
        if found is None:
            raise ValueError(
                f"shape {name!r} is neither a built-in shape nor a specimen of the "
                f"configuration; valid: {', '.join(self.specimen_names)}"
            )
        return found

    def material(self, name: str) -> Material:
        """The material ``name`` names; a one-line ``ValueError`` naming the valid ones
        otherwise."""
        found = self.materials.get(name)
        if found is None:
            raise ValueError(
                f"material {name!r} is not a material of the configuration; valid: "
                f"{', '.join(self.materials)}"
            )
        return found

    def with_material(self, material: Material) -> Self:
        """A copy with ``material`` replacing the entry of the same name."""
        mats = dict(self.materials)
        if material.name not in mats:
            raise ValueError(
                f"material.name must be one of {', '.join(mats)}; got {material.name!r}"
            )
        mats[material.name] = material
        return dataclasses.replace(self, materials=mats)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable dict of every parameter. ``specimens`` holds each
        specimen's record (``shapes.specimen_to_dict``: its vertices, height and geometry
        hash) and is left out when there are none, as the paper's set-up has."""
        out = params.to_dict(dataclasses.replace(self, specimens={}))
        del out["specimens"]
        if self.specimens:
            out["specimens"] = {name: specimen_to_dict(s) for name, s in self.specimens.items()}
        return out

    @classmethod
    def from_dict(cls, data: Any) -> SynthConfig:
        """Rebuild from :meth:`to_dict` output; unknown or missing keys raise ValueError
        (``specimens`` may be absent: none)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"SynthConfig must be a mapping; got {type(data).__name__}")
        records = data.get("specimens", {})
        if not isinstance(records, Mapping):
            raise ValueError(
                f"SynthConfig.specimens must be a mapping; got {type(records).__name__}"
            )
        specimens: dict[str, Specimen] = {}
        for name, record in records.items():
            try:
                spec = specimen_from_dict(record)
            except ValueError as exc:
                raise ValueError(f"SynthConfig.specimens.{name}: {exc}") from None
            if not isinstance(spec, Specimen):
                raise ValueError(
                    f"SynthConfig.specimens.{name}: a built-in shape needs no entry here"
                )
            specimens[str(name)] = spec
        base = params.from_dict(cls, {**data, "specimens": {}})
        return dataclasses.replace(base, specimens=specimens) if specimens else base


def default_synth_config() -> dict[str, Any]:
    """The simulator's default settings as a generation configuration stores them."""
    return SynthConfig().to_dict()


def validate_synth_config(synth: Mapping[str, Any]) -> None:
    """``ValueError`` unless ``synth`` holds valid simulator settings (every reader of a
    stored configuration checks it here)."""
    SynthConfig.from_dict(dict(synth))
