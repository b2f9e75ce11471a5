"""The global physical parameters a calibration may fit, each with its cited range: the one
table both the sweep and ``tactile-synth calibrate`` read names and ranges from.

Every parameter of :data:`synth.calibration.settings.SWEEP` is here, its range the span of
its cited candidates; :data:`EXTRA` adds the readout and noise figures a lab's own
hardware sets that the sweep does not measure. A name is ``SECTION.FIELD`` as ``--set``
takes it (:func:`synth.calibration.settings.with_value` applies it). A range spanning a
factor of ten or more is searched on a log scale.

Examples
--------
>>> p = parameter("acquisition.mains_v")
>>> p.low, p.high, p.log
(0.0003, 0.003, True)
>>> parameter("finger.skin_modulus_pa").bounded(0.2e6, 0.4e6).low
200000.0
>>> try:
...     parameter("finger.skin_modulus_pa").bounded(0.05e6, 0.4e6)
... except CalibrationError as exc:
...     print(exc)
--parameters finger.skin_modulus_pa: bounds 50000..400000 lie outside its cited range 100000..580000
"""

from __future__ import annotations

import dataclasses
import difflib
import math

from .settings import SWEEP, CalibrationError

#: Parameters the sweep does not measure, as ``(section, field, (low, high), why)``.
EXTRA: tuple[tuple[str, str, tuple[float, float], str], ...] = (
    (
        "pvdf",
        "post_gain",
        (0.5, 2.0),
        "the films' voltage gain after the charge amplifier: a lab's own readout; the "
        "gain rule's round choices (0.5, 1, 2) next to the default, above which the "
        "sharpest edges leave the DAQ's +-10 V",
    ),
    (
        "acquisition",
        "noise_v_rms",
        (0.15e-3, 0.65e-3),
        "white noise at the DAQ's input: half a code to two codes of a 16-bit +-10 V "
        "input (0.305 mV a code), the random-noise figure of the NI USB-6346 class",
    ),
)


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One calibratable parameter: ``section.field``, its cited range and why."""

    section: str
    field: str
    low: float
    high: float
    why: str

    @property
    def name(self) -> str:
        return f"{self.section}.{self.field}"

    @property
    def log(self) -> bool:
        """Whether the range is searched on a log scale (it spans ten times or more)."""
        return self.low > 0 and self.high / self.low >= 10.0 - 1e-9

    def bounded(self, low: float, high: float) -> Parameter:
        """This parameter over ``low..high``, which must lie inside its cited range."""
        if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
            raise CalibrationError(
                f"--parameters {self.name}: bounds must be two finite numbers LOW:HIGH with "
                f"LOW < HIGH; got {low:g}:{high:g}"
            )
        tol = 1e-9 * (self.high - self.low)
        if low < self.low - tol or high > self.high + tol:
            raise CalibrationError(
                f"--parameters {self.name}: bounds {low:g}..{high:g} lie outside its cited "
                f"range {self.low:g}..{self.high:g}"
            )
        return dataclasses.replace(self, low=float(low), high=float(high))

    def from_unit(self, u: float) -> float:
        """The value at ``u`` in 0..1 of the range (log-spaced where :attr:`log`)."""
        if self.log:
            return float(math.exp(math.log(self.low) + u * math.log(self.high / self.low)))
        return float(self.low + u * (self.high - self.low))

    def to_unit(self, value: float) -> float:
        """Where ``value`` lies in the range, 0..1 (log-spaced where :attr:`log`)."""
        if self.log:
            return math.log(value / self.low) / math.log(self.high / self.low)
        return (value - self.low) / (self.high - self.low)


def _registry() -> dict[str, Parameter]:
    out: dict[str, Parameter] = {}
    for section, field, values, why in SWEEP:
        out[f"{section}.{field}"] = Parameter(section, field, min(values), max(values), why)
    for section, field, (low, high), why in EXTRA:
        out[f"{section}.{field}"] = Parameter(section, field, low, high, why)
    return out


#: Every calibratable parameter by name.
PARAMETERS: dict[str, Parameter] = _registry()


def parameter(name: str) -> Parameter:
    """The parameter ``name``; a one-line refusal naming the closest known one."""
    if name not in PARAMETERS:
        close = difflib.get_close_matches(name, list(PARAMETERS), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise CalibrationError(
            f"--parameters: unknown parameter {name!r}{hint}; `tactile-synth calibrate "
            "--list-parameters` lists them"
        )
    return PARAMETERS[name]


def parse_parameters(items: list[str]) -> list[Parameter]:
    """``NAME`` or ``NAME=LOW:HIGH`` items as parameters, each named once."""
    out: list[Parameter] = []
    for item in items:
        name, sep, bounds = item.partition("=")
        p = parameter(name)
        if sep:
            low, colon, high = bounds.partition(":")
            try:
                if not colon:
                    raise ValueError
                lo, hi = float(low), float(high)
            except ValueError:
                raise CalibrationError(
                    f"--parameters {name}: bounds must be LOW:HIGH; got {bounds!r}"
                ) from None
            p = p.bounded(lo, hi)
        if any(q.name == p.name for q in out):
            raise CalibrationError(f"--parameters names {name} twice")
        out.append(p)
    if not out:
        raise CalibrationError("--parameters needs at least one parameter name")
    return out
