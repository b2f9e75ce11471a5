"""The shipped physical families: changes of the world the finger slides through,
simulated through MuJoCo (never applied to the recorded signals). Each rewrites the
nominal test set's generation configuration; ``docs/stress.md`` gives the reasoning
behind every range.

Every family keeps the trials' seeds (the test set's configuration asks for seeds that do
not depend on the force and speed, :attr:`synth.presets.GenerationConfig.seed_by_condition`),
so a family's severities share each stroke's placement, surface stretch and noise, and
differ in the perturbation alone; at severity 0 the configuration is the nominal one.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping
from typing import Any

import shapely

from synth.presets import FORCE_RANGE_N, SPEED_RANGE_MM_S, GenerationConfig, in_range

from .families import PhysicalFamily


def _condition(config: GenerationConfig) -> tuple[float, float]:
    if len(config.conditions) != 1:
        raise ValueError(
            "the stress suite needs a nominal test set of one force/speed condition; got "
            f"{len(config.conditions)}"
        )
    return config.conditions[0]


def _synth(config: GenerationConfig) -> dict[str, Any]:
    """The simulator settings of ``config``, resolved (a copy to change)."""
    from synth import SynthConfig

    base = SynthConfig().to_dict() if config.synth is None else config.synth
    return copy.deepcopy(dict(base))


def _with_synth(
    config: GenerationConfig, change: Callable[[dict[str, Any]], None]
) -> GenerationConfig:
    from synth import SynthConfig

    settings = _synth(config)
    change(settings)
    SynthConfig.from_dict(settings)  # every field still in its valid range
    return config.replace(synth=settings)


class Force(PhysicalFamily):
    """The robot presses harder than at enrolment: a heavier tool, another force
    controller, a set-point changed for another task."""

    name = "force"
    summary = "normal force raised (simulated)"
    unit = "x nominal force"
    nominal = 1.0
    levels = (1.5, 1.75, 2.0, 2.5, 3.0)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if value <= 0:
            raise ValueError(f"force: a factor {value:g} gives no contact force (> 0 needed)")
        if config is not None:
            force = _condition(config)[0] * value
            lo, hi = FORCE_RANGE_N
            if not in_range(force, FORCE_RANGE_N):
                raise ValueError(
                    f"force x{value:g}: {force:g} N lies outside {lo:g}..{hi:g} N, the range "
                    "the simulator reproduces"
                )

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        force, _ = _condition(config)
        return config if value == self.nominal else config.replace(forces_n=(force * value,))


class Speed(PhysicalFamily):
    """The robot slides faster than at enrolment (a shorter cycle time)."""

    name = "speed"
    summary = "sliding speed raised (simulated)"
    unit = "x nominal speed"
    nominal = 1.0
    levels = (1.4, 1.6, 1.8, 2.0, 2.2)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if value <= 0:
            raise ValueError(f"speed: a factor {value:g} gives no sliding (> 0 needed)")
        if config is not None:
            speed = _condition(config)[1] * value
            lo, hi = SPEED_RANGE_MM_S
            if not in_range(speed, SPEED_RANGE_MM_S):
                raise ValueError(
                    f"speed x{value:g}: {speed:g} mm/s lies outside {lo:g}..{hi:g} mm/s, the "
                    "range the simulator accepts (faster slides run off the plate)"
                )

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        _, speed = _condition(config)
        return config if value == self.nominal else config.replace(speeds_mm_s=(speed * value,))


def _set(path: tuple[str, ...], value: float) -> Callable[[dict[str, Any]], None]:
    def change(settings: dict[str, Any]) -> None:
        table: Any = settings
        for key in path[:-1]:
            table = table[key]
        table[path[-1]] = value

    return change


class Yaw(PhysicalFamily):
    """The specimen sits turned in its fixture: the path crosses its outline at another
    angle and its surface marks run at an angle to the fingerprint's ridges."""

    name = "yaw"
    summary = "specimen turned in its fixture (simulated)"
    unit = "deg"
    nominal = 0.0
    levels = (1.0, 2.0, 4.0, 8.0, 15.0)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if not -90.0 < value < 90.0:
            raise ValueError(f"yaw {value:g} deg: the specimen must turn by less than 90 deg")

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        if value == self.nominal:
            return config
        return _with_synth(config, _set(("motion", "specimen_yaw_rad"), math.radians(value)))


class Offset(PhysicalFamily):
    """The finger crosses the specimen off its enrolled line, towards and across the
    specimen's centre line: a re-mounted fixture, another robot's calibration."""

    name = "offset"
    summary = "lateral path offset (simulated)"
    unit = "mm"
    nominal = 0.0
    levels = (0.5, 1.0, 2.0, 3.0, 4.0)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if config is None:
            return
        y = _synth(config)["motion"]["path_y_m"] - value * 1e-3
        if abs(y) > 10e-3:
            raise ValueError(
                f"offset {value:g} mm: the path at {y * 1e3:g} mm from the specimens' centre "
                "line leaves the plate's usable width (+-10 mm)"
            )
        for name, outline in _outlines(config):
            line = shapely.LineString([(-0.05, y), (0.05, y)])
            if outline.intersection(line).length <= 0:
                raise ValueError(
                    f"offset {value:g} mm: the path at y = {y * 1e3:g} mm misses the "
                    f"specimen {name}"
                )

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        if value == self.nominal:
            return config
        y0 = _synth(config)["motion"]["path_y_m"]
        return _with_synth(config, _set(("motion", "path_y_m"), y0 - value * 1e-3))


def _outlines(config: GenerationConfig) -> list[tuple[str, Any]]:
    """``(name, shapely outline)`` of every specimen of ``config``'s grid."""
    import shapes

    user = _synth(config).get("specimens") or {}
    out = []
    for name in config.shapes:
        spec = shapes.specimen_from_dict(user[name]) if name in user else name
        out.append((name, shapes.outline(spec)))
    return out


class Pitch(PhysicalFamily):
    """The finger meets the surface at another angle: a re-mounted end-effector, a
    different approach pose."""

    name = "pitch"
    summary = "finger pitch (contact angle) changed (simulated)"
    unit = "deg"
    nominal = 0.0
    levels = (2.0, 4.0, 6.0, 10.0, 15.0)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if not -30.0 <= value <= 30.0:
            raise ValueError(f"pitch {value:g} deg: the finger's pad tilts by at most 30 deg")

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        if value == self.nominal:
            return config
        return _with_synth(config, _set(("finger", "pitch_rad"), math.radians(value)))


class SkinHardness(PhysicalFamily):
    """The silicone skin is stiffer than at enrolment: aged, or cold."""

    name = "skin"
    summary = "skin modulus raised: ageing, cold (simulated)"
    unit = "x nominal modulus"
    nominal = 1.0
    levels = (1.25, 1.5, 2.0, 3.0, 4.0)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if value <= 0:
            raise ValueError(f"skin x{value:g}: a modulus must stay > 0")

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        if value == self.nominal:
            return config
        from synth import SynthConfig
        from synth.skin_fit import fit_skin_contact

        def change(settings: dict[str, Any]) -> None:
            finger = settings["finger"]
            finger["skin_modulus_pa"] = finger["skin_modulus_pa"] * value
            # MuJoCo's contact of the stiffer skin, fitted to its Hertz law as the
            # nominal skin's is (synth.skin_fit), so that the simulated indentation
            # follows the new modulus.
            solref, solimp = fit_skin_contact(SynthConfig.from_dict(settings))
            finger["skin_solref"], finger["skin_solimp"] = list(solref), list(solimp)

        return _with_synth(config, change)


class SurfaceFriction(PhysicalFamily):
    """The specimens' surfaces are contaminated or worn: dust, a film of grease or moisture,
    polish from use lower the skin's friction on every material alike."""

    name = "friction"
    summary = "surface friction lowered: contamination, wear (simulated)"
    unit = "x nominal friction"
    nominal = 1.0
    levels = (0.85, 0.7, 0.55, 0.4, 0.3)

    def check(self, value: float, config: GenerationConfig | None) -> None:
        if not 0 < value <= 3:
            raise ValueError(f"friction x{value:g}: the factor must lie in 0..3")

    def configure(self, config: GenerationConfig, value: float) -> GenerationConfig:
        if value == self.nominal:
            return config

        def change(settings: dict[str, Any]) -> None:
            materials: Mapping[str, Any] = settings["materials"]
            for material in materials.values():
                law = material["friction"]
                law["kinetic"] = law["kinetic"] * value
                law["static"] = law["static"] * value

        return _with_synth(config, change)
