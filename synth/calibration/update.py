"""Not a calibration: the surface update period (``Motion.surface_update_s``, a numerical
choice) against a 1 ms update on the same trials: the films' power in the band an
update-rate artefact shows in, and each channel group's difference from the 1 ms run,
with the difference between two seeds for scale."""

from __future__ import annotations

import numpy as np

from shapes import SHAPE_NAMES

from ..config import SynthConfig
from ..materials import MATERIAL_NAMES
from ..trial import CHANNELS, SAMPLE_RATE_HZ, TrialSpec
from .settings import with_value

#: Surface update periods ``update`` compares: the first is the reference.
UPDATE_PERIODS_S = (0.001, 0.002, 0.004)
#: Speeds ``update`` compares them at: the presets' 6, 10 and 14 mm/s, a slow slide that
#: sticks and slips, and the fastest a grid may ask for.
UPDATE_SPEEDS_MM_S = (2.0, 6.0, 10.0, 14.0, 22.0)
#: The band an update-rate artefact shows in: above the texture's strongest tones.
UPDATE_BAND_HZ = 150.0


def update_convergence(
    config: SynthConfig,
    periods: tuple[float, ...] = UPDATE_PERIODS_S,
    *,
    speeds: tuple[float, ...] = UPDATE_SPEEDS_MM_S,
    shapes: tuple[str, ...] = SHAPE_NAMES,
    materials: tuple[str, ...] = MATERIAL_NAMES,
) -> dict:
    """The same trials (every shape x material, seed 0, at each of ``speeds``) simulated
    with each surface update period in ``periods``, compared with the first. One row per
    later period and speed: the films' power above :data:`UPDATE_BAND_HZ` as a ratio to
    the reference's (median and largest over the trials), and the RMS difference of the
    films' and of the gauges' mean-removed signals from the reference's, relative to the
    reference's RMS (median and 95th percentile). ``"seeds"``: per speed, the same
    differences between seeds 0 and 1 at ``config``'s own period, for scale."""
    from ..simulator import simulate_batch

    films = [i for i, c in enumerate(CHANNELS) if c.startswith("pvdf")]
    gauges = [i for i, c in enumerate(CHANNELS) if c.startswith("sg")]
    specs = [(v, s, m) for v in speeds for s in shapes for m in materials]
    at = {v: np.array([i for i, sp in enumerate(specs) if sp[0] == v]) for v in speeds}

    def run(period: float, seed: int) -> np.ndarray:
        cfg = with_value(config, "motion", "surface_update_s", period)
        batch = [TrialSpec(s, m, speed_mm_s=v, seed=seed) for v, s, m in specs]
        sig = np.stack([t.signals for t in simulate_batch(batch, config=cfg)])
        return sig - sig.mean(axis=-1, keepdims=True)

    def band_power(sig: np.ndarray) -> np.ndarray:
        spec = np.abs(np.fft.rfft(sig[:, films], axis=-1)) ** 2
        freq = np.fft.rfftfreq(sig.shape[-1], 1.0 / SAMPLE_RATE_HZ)
        return spec[..., freq >= UPDATE_BAND_HZ].sum(axis=(1, 2))

    def differences(a: np.ndarray, b: np.ndarray) -> dict:
        out = {}
        for name, group in (("pvdf", films), ("sg", gauges)):
            num = np.sqrt(((a[:, group] - b[:, group]) ** 2).mean(axis=-1))
            d = (num / np.sqrt((b[:, group] ** 2).mean(axis=-1))).ravel()
            out[f"{name}_diff_median"] = float(np.median(d))
            out[f"{name}_diff_p95"] = float(np.percentile(d, 95))
        return out

    # Seed 0 at every period, each simulated once (the default period is usually one of
    # them, and the seeds' comparison reuses its run).
    runs = {period: run(period, 0) for period in dict.fromkeys(periods)}
    ref = runs[periods[0]]
    ref_power = band_power(ref)
    rows = []
    for period in periods[1:]:
        sig = runs[period]
        ratio = band_power(sig) / ref_power
        for v, idx in at.items():
            rows.append(
                {
                    "surface_update_s": period,
                    "speed_mm_s": v,
                    "band_power_ratio_median": float(np.median(ratio[idx])),
                    "band_power_ratio_max": float(ratio[idx].max()),
                    **differences(sig[idx], ref[idx]),
                }
            )
    own = config.motion.surface_update_s
    same = runs[own] if own in runs else run(own, 0)
    other = run(own, 1)
    seeds = {v: differences(other[idx], same[idx]) for v, idx in at.items()}
    return {"reference_s": periods[0], "rows": rows, "seeds": seeds, "trials": len(specs)}
