"""Finger files: a twin's global physical parameters as TOML, the file
``tactile-synth calibrate`` writes and ``generate --finger FILE`` and experiment files
(``finger = "FILE"``) load::

    # fitted by tactile-synth calibrate
    [pvdf]
    post_gain = 1.2
    feedback_resistance_ohm = 8.1e7
    [materials]
    texture_scale = 0.9                 # a factor on every material's texture

Each table is a configuration section and each key one of its numeric fields, or a
setting ``--set`` knows (:func:`synth.calibration.settings.parse_set`: the materials'
texture scale, the Stribeck velocity, one gauge's height as ``gauge_heights_m.0``).
Applied in the file's order on top of a configuration; a changed skin modulus refits the
skin's contact as ``--set`` does.

Examples
--------
>>> import tempfile, pathlib
>>> from synth import SynthConfig
>>> path = pathlib.Path(tempfile.mkdtemp()) / "finger.toml"
>>> write_finger(path, {"acquisition.mains_v": 2e-3, "variability.force_rel": 0.1})
>>> load_finger(path)
{('acquisition', 'mains_v'): 0.002, ('variability', 'force_rel'): 0.1}
>>> apply_finger(SynthConfig(), path).acquisition.mains_v
0.002
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..config import SynthConfig
from .settings import CalibrationError, parse_set, with_value


def write_finger(
    path: str | os.PathLike, values: Mapping[str, float], comments: Sequence[str] = ()
) -> Path:
    """Write ``values`` (``{"SECTION.FIELD": value}``) as a finger file at ``path``,
    ``comments`` as its header lines."""
    by_section: dict[str, list[tuple[str, float]]] = {}
    for name, value in values.items():
        section, _, field = name.partition(".")
        by_section.setdefault(section, []).append((field, float(value)))
    lines = [f"# {c}" for c in comments]
    for section, items in by_section.items():
        lines.append(f"[{section}]")
        lines += [f"{_key(field)} = {value!r}" for field, value in items]
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, path)
    return path


def _key(field: str) -> str:
    return f'"{field}"' if "." in field else field


def load_finger(path: str | os.PathLike, *, arg: str = "--finger") -> dict[tuple[str, str], float]:
    """The settings of the finger file ``path``; a one-line ``ValueError`` naming ``arg``,
    the file and the entry on a bad file."""
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise CalibrationError(f"{arg} {path}: no such file") from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise CalibrationError(f"{arg} {path}: not a readable TOML file ({exc})") from None
    items = []
    for section, table in data.items():
        if not isinstance(table, Mapping):
            raise CalibrationError(
                f"{arg} {path}: {section!r} must be a table [SECTION] of fields; got {table!r}"
            )
        for field, value in table.items():
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise CalibrationError(
                    f"{arg} {path}: {section}.{field} must be a number; got {value!r}"
                )
            items.append(f"{section}.{field}={value!r}")
    if not items:
        raise CalibrationError(f"{arg} {path}: the file sets nothing")
    try:
        return parse_set(items)
    except CalibrationError as exc:
        raise CalibrationError(f"{arg} {path}: {str(exc).replace('--set ', '')}") from None


def apply_finger(
    config: SynthConfig, path: str | os.PathLike, *, arg: str = "--finger"
) -> SynthConfig:
    """``config`` with the finger file's settings applied in its order."""
    for (section, field), value in load_finger(path, arg=arg).items():
        try:
            config = with_value(config, section, field, value)
        except ValueError as exc:
            raise CalibrationError(f"{arg} {path}: {section}.{field}={value:g}: {exc}") from None
    return config
