"""What the films read of a material's texture while the finger slides steadily.

    python3 scripts/bench_texture.py [--seeds 3] [--speeds 6 10 14] [--force 1.0]
                                     [--friction-model shared|derived|both]
                                     [--skin-response elastic|viscoelastic|both]
                                     [--set SECTION.FIELD=VALUE ...]
                                     [--texture MATERIAL.FIELD=VALUE ...]

Slides the finger over the square's top at ``--force`` newtons, at each speed and on
each material, and keeps the steady-sliding segment of the window: the samples whose
pad axis lies on the top at least ``--margin-mm`` (3 mm) from every wall, the longest
such run. On it, the films' RMS in the texture band (20-400 Hz, a 4th-order
Butterworth band-pass run forwards and backwards) is averaged over the two films and
the seeds. Prints one row per material and speed, then the two checks of the texture
targets: wood's RMS at least 3 times aluminium's at 10 mm/s, and the RMS rising from
the slowest to the fastest speed on every material. Then the same band's RMS of the
texture's push on the skin (the tangential force ``-slope * F_n`` the simulated contact
feels, ``Trial.truth["texture_push_n"]``) on the same segments, and the films' RMS per
unit of it: the input the surface gives and what the finger's mechanics make of it.
``--skin-response`` chooses how the skin answers the texture
(``Finger.skin_texture_response``: its relaxed modulus, or the silicone's complex
modulus at the frequency the texture is passed at); ``both`` measures each friction
model under each, side by side (JSON keys ``MODEL`` for the elastic skin,
``MODEL+viscoelastic`` for the other).
``--set SECTION.FIELD=VALUE`` measures another configuration (as
``tactile-synth calibrate --whatif``), at the films' post-gain ``scripts/calibrate.py
gain`` sizes for it unless ``--set pvdf.post_gain=G`` holds one.
``--texture wood.correlation_length_m=50e-6`` measures a material with another value
of its random roughness (``roughness_rms_m`` or ``correlation_length_m``), e.g. a free
choice at either end of its plausible range.

    python3 scripts/bench_texture.py --transfer [40 70 100 170 250] [--seeds 3]

measures instead how the finger carries a push of each frequency to the films: the
resin specimen's texture is replaced by a pure sinusoid (no roughness) whose wavelength
puts it at each frequency at 10 mm/s (slope amplitude 0.02), and on the steady segments
the films' RMS and the push's, each in a band of +-15 % about the frequency, give the
films' output per unit of push. A finger whose films read the contact's traction gives
the same ratio at every frequency, up to the pad's own modes above the band.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

import numpy as np
import shapely
from scipy import signal

import shapes
import synth
from synth import tribology
from synth.calibration.settings import with_value
from synth.contact import friction_coefficient
from synth.trial import SAMPLE_RATE_HZ, TrialSpec
from synth.tribology import with_friction_model
from tactile_synth.validation import int_arg, parse_number

BAND_HZ = (20.0, 400.0)


def steady_segment(trial: synth.Trial, margin_m: float) -> slice | None:
    """The longest run of the window's samples whose pad axis is on the outline's top at
    least ``margin_m`` from every wall (``None`` if there is none of 0.2 s)."""
    poly = shapes.outline(trial.spec.shape)
    pts = shapely.points(trial.truth["finger_x_m"], trial.truth["finger_y_m"])
    inside = shapely.contains(poly, pts) & (shapely.distance(pts, poly.exterior) >= margin_m)
    padded = np.concatenate([[0], inside.astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(padded))
    if edges.size == 0:
        return None
    starts, ends = edges[::2], edges[1::2]
    best = int(np.argmax(ends - starts))
    if ends[best] - starts[best] < 0.2 * SAMPLE_RATE_HZ:
        return None
    return slice(int(starts[best]), int(ends[best]))


def band_rms(x: np.ndarray, band_hz: tuple[float, float] = BAND_HZ) -> float:
    """RMS of ``x`` (1 kHz) in ``band_hz`` (4th-order Butterworth, forwards and back)."""
    sos = signal.butter(4, band_hz, btype="bandpass", fs=SAMPLE_RATE_HZ, output="sos")
    return float(np.sqrt(np.mean(signal.sosfiltfilt(sos, x - x.mean()) ** 2)))


def films_and_push(
    trial: synth.Trial, margin_m: float, band_hz: tuple[float, float] = BAND_HZ
) -> tuple[float, float]:
    """On ``trial``'s steady segment: the films' RMS in ``band_hz`` (mean of the two
    films, volts) and the texture push's (newtons); exits naming the trial if it has no
    steady segment."""
    seg = steady_segment(trial, margin_m)
    if seg is None:
        raise SystemExit(f"bench_texture: no steady segment in {trial.spec}")
    films = np.mean([band_rms(trial.signals[c, seg].astype(float), band_hz) for c in (0, 1)])
    push = band_rms(np.asarray(trial.truth["texture_push_n"][seg], dtype=float), band_hz)
    return float(films), push


def measure(
    config: synth.SynthConfig,
    speeds: list[float],
    seeds: int,
    force_n: float,
    margin_m: float,
    shape: str = "square",
) -> tuple[dict[str, dict[float, float]], dict[str, dict[float, float]]]:
    """``(films, push)`` per material and speed on the steady segments: the films' mean
    texture-band RMS (volts, averaged over the two films and ``seeds`` trials) and the
    texture push's (newtons, averaged over the trials)."""
    specs = [
        TrialSpec(shape, m, force_n=force_n, speed_mm_s=v, seed=s)
        for m in synth.MATERIAL_NAMES
        for v in speeds
        for s in range(seeds)
    ]
    trials = synth.simulate_batch(specs, config=config)
    films: dict[str, dict[float, list[float]]] = {}
    push: dict[str, dict[float, list[float]]] = {}
    for t in trials:
        rms, felt = films_and_push(t, margin_m)
        films.setdefault(t.spec.material, {}).setdefault(t.spec.speed_mm_s, []).append(rms)
        push.setdefault(t.spec.material, {}).setdefault(t.spec.speed_mm_s, []).append(felt)

    def means(table: dict[str, dict[float, list[float]]]) -> dict[str, dict[float, float]]:
        return {m: {v: float(np.mean(r)) for v, r in by.items()} for m, by in table.items()}

    return means(films), means(push)


#: The sinusoid of ``--transfer``: its slope amplitude and the speed it is slid at.
TRANSFER_SLOPE = 0.02
TRANSFER_SPEED_MM_S = 10.0


def transfer(
    config: synth.SynthConfig,
    freqs_hz: list[float],
    seeds: int,
    force_n: float,
    margin_m: float,
) -> dict[float, tuple[float, float]]:
    """Per frequency ``(films_v, push_n)``: the films' RMS (mean of the two films) and the
    push's in a band of +-15 % about the frequency, on the steady segments of ``seeds``
    trials over the square whose resin top is a pure sinusoid at that frequency."""
    out = {}
    speed_m_s = TRANSFER_SPEED_MM_S * 1e-3
    for f in freqs_hz:
        wavelength = speed_m_s / f
        wave = synth.materials.Texture(
            0.0,
            1e-4,
            (synth.materials.Periodic(wavelength, TRANSFER_SLOPE * wavelength / (2 * np.pi)),),
        )
        cfg = config.with_material(dataclasses.replace(config.materials["resin"], texture=wave))
        specs = [
            TrialSpec("square", "resin", force_n=force_n, speed_mm_s=TRANSFER_SPEED_MM_S, seed=s)
            for s in range(seeds)
        ]
        films, push = [], []
        band = (0.85 * f, 1.15 * f)
        for t in synth.simulate_batch(specs, config=cfg):
            rms, felt = films_and_push(t, margin_m, band)
            films.append(rms)
            push.append(felt)
        out[f] = (float(np.mean(films)), float(np.mean(push)))
    return out


#: The texture fields ``--texture`` may change (as ``--set materials.MATERIAL.FIELD``).
TEXTURE_FIELDS = ("roughness_rms_m", "correlation_length_m")


def with_texture(config: synth.SynthConfig, items: list[str]) -> synth.SynthConfig:
    """``config`` with each ``MATERIAL.FIELD=VALUE`` of ``items`` set on that material's
    texture; a one-line ``ValueError`` names a malformed or unknown item."""
    for item in items:
        name, eq, value = item.partition("=")
        material, dot, field = name.partition(".")
        if not (eq and dot):
            raise ValueError(f"--texture {item!r}: write MATERIAL.FIELD=VALUE")
        if material not in config.materials:
            known = ", ".join(sorted(config.materials))
            raise ValueError(f"--texture {item!r}: no material {material!r} (known: {known})")
        if field not in TEXTURE_FIELDS:
            raise ValueError(
                f"--texture {item!r}: FIELD must be one of {', '.join(TEXTURE_FIELDS)}"
            )
        try:
            config = with_value(config, "materials", f"{material}.{field}", parse_number(value))
        except ValueError as exc:
            raise ValueError(f"--texture {item!r}: {exc}") from None
    return config


def print_friction(config: synth.SynthConfig, speeds: list[float], force_n: float) -> None:
    """Each material's sliding coefficient under ``config``'s law at every speed, and for
    the derived model its hysteresis and adhesive parts and real contact fraction."""
    print(f"kinetic friction at {force_n:g} N (the law's coefficient at each speed)")
    print("material    " + "".join(f"{v:>9g} mm/s" for v in speeds))
    for name in synth.MATERIAL_NAMES:
        law = config.materials[name].friction
        mus = [float(friction_coefficient(law, v * 1e-3, force_n)) for v in speeds]
        print(f"{name:<12}" + "".join(f"{m:>14.3f}" for m in mus))
    for name in synth.MATERIAL_NAMES:
        mat = config.materials[name]
        if mat.friction.velocity_exponent == 0.0:
            continue
        f = tribology.friction(
            mat.texture,
            config.finger,
            tribology.SILICONE_TRIBOLOGY,
            speed_m_s=tribology.REFERENCE_SPEED_M_S,
            force_n=force_n,
        )
        print(
            f"  {name}: hysteresis {f.hysteresis:.4f} + adhesion {f.adhesion:.4f} at 10 mm/s, "
            f"real contact {100 * f.contact_fraction:.1f} % of the nominal area"
        )


def report(config: synth.SynthConfig, speeds: list[float], args: argparse.Namespace) -> dict:
    """Measure and print the materials' table under ``config``; returns it."""
    table, push = measure(config, speeds, args.seeds, args.force, args.margin_mm * 1e-3)
    print(f"films' {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz RMS (mV) on the square's steady top, ")
    print(f"{args.force:g} N, mean of 2 films x {args.seeds} seeds")
    print("material    " + "".join(f"{v:>9g} mm/s" for v in speeds))
    for m in synth.MATERIAL_NAMES:
        print(f"{m:<12}" + "".join(f"{table[m][v] * 1e3:>14.3f}" for v in speeds))
    ref = 10.0 if 10.0 in speeds else speeds[len(speeds) // 2]
    ratio = table["wood"][ref] / table["aluminum"][ref]
    rising = {m: table[m][speeds[-1]] > table[m][speeds[0]] for m in synth.MATERIAL_NAMES}
    print(f"wood / aluminium at {ref:g} mm/s: {ratio:.2f} (target >= 3)")
    print(
        f"rises from {speeds[0]:g} to {speeds[-1]:g} mm/s: "
        + ", ".join(f"{m} {'yes' if r else 'NO'}" for m, r in rising.items())
    )
    print(f"texture push on the skin, {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz RMS (mN), same segments")
    print("material    " + "".join(f"{v:>9g} mm/s" for v in speeds))
    for m in synth.MATERIAL_NAMES:
        print(f"{m:<12}" + "".join(f"{push[m][v] * 1e3:>14.3f}" for v in speeds))
    print("films per unit of push (mV/mN)")
    for m in synth.MATERIAL_NAMES:
        print(f"{m:<12}" + "".join(f"{table[m][v] / push[m][v]:>14.3f}" for v in speeds))
    return {
        "films_v": {m: {str(v): r for v, r in by.items()} for m, by in table.items()},
        "push_n": {m: {str(v): r for v, r in by.items()} for m, by in push.items()},
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int_arg, default=3)
    parser.add_argument("--speeds", type=float, nargs="+", default=[6.0, 10.0, 14.0])
    parser.add_argument("--force", type=float, default=1.0)
    parser.add_argument("--margin-mm", type=float, default=3.0)
    parser.add_argument("--json", help="also write the table to this JSON file")
    parser.add_argument(
        "--friction-model",
        choices=("shared", "derived", "both"),
        default="both",
        help="the materials' friction: the shared silicone law, the laws derived from "
        "each surface's roughness (synth.tribology), or both side by side (default)",
    )
    parser.add_argument(
        "--skin-response",
        choices=("elastic", "viscoelastic", "both"),
        default="elastic",
        help="how the skin answers the texture: its relaxed modulus (default), the "
        "silicone's complex modulus (Finger.skin_texture_response), or both side by side",
    )
    parser.add_argument(
        "--transfer",
        type=float,
        nargs="*",
        metavar="HZ",
        help="the films per unit of push on a pure sinusoid at these frequencies "
        "(default 40 70 100 170 250 Hz) instead of the materials' table",
    )
    parser.add_argument(
        "--set",
        action="append",
        metavar="SECTION.FIELD=VALUE",
        help="measure another configuration (as tactile-synth calibrate --whatif --set)",
    )
    parser.add_argument(
        "--texture",
        action="append",
        metavar="MATERIAL.FIELD=VALUE",
        help="measure a material with another roughness_rms_m or correlation_length_m",
    )
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    if args.force <= 0 or min(args.speeds) <= 0 or args.margin_mm < 0:
        parser.error("--force and --speeds must be > 0 and --margin-mm >= 0")
    config = synth.SynthConfig()
    if args.set:
        from synth.calibration.gain import configured_at_own_gain
        from synth.calibration.settings import CalibrationError

        try:  # the films' gain sized for them, as whatif does
            config = configured_at_own_gain(args.set)
        except (CalibrationError, synth.SimulationError) as exc:
            raise SystemExit(f"--set: {exc}") from None
        print(f"films' post-gain {config.pvdf.post_gain:g}")
    if args.texture:
        try:
            config = with_texture(config, args.texture)
        except ValueError as exc:
            parser.error(str(exc))
    if args.transfer is not None:
        freqs = sorted(args.transfer) or [40.0, 70.0, 100.0, 170.0, 250.0]
        if freqs[0] < BAND_HZ[0] / 0.85 or freqs[-1] > BAND_HZ[1] / 1.15:
            parser.error(
                f"--transfer frequencies must lie in {BAND_HZ[0] / 0.85:.1f}.."
                f"{BAND_HZ[1] / 1.15:.1f} Hz (their +-15 % band inside the texture band)"
            )
        res = transfer(config, freqs, args.seeds, args.force, args.margin_mm * 1e-3)
        print(
            f"a pure sinusoid (slope amplitude {TRANSFER_SLOPE:g}) on the square's top at "
            f"{TRANSFER_SPEED_MM_S:g} mm/s, {args.force:g} N, mean of {args.seeds} seeds; RMS "
            "in +-15 % about each frequency"
        )
        print("frequency   films (mV)   push (mN)   films per push (mV/mN)")
        for f, (films, push) in res.items():
            print(f"{f:>6g} Hz {films * 1e3:>12.3f} {push * 1e3:>11.3f} {films / push:>14.3f}")
        ratios = [films / push for films, push in res.values()]
        print(f"highest over lowest ratio: {max(ratios) / min(ratios):.3f}")
        if args.json:
            with open(args.json, "w") as fh:
                json.dump({str(f): {"films_v": a, "push_n": b} for f, (a, b) in res.items()}, fh)
        return 0
    speeds = sorted(args.speeds)
    models = ("shared", "derived") if args.friction_model == "both" else (args.friction_model,)
    responses = (
        ("elastic", "viscoelastic") if args.skin_response == "both" else (args.skin_response,)
    )
    results = {}
    for response in responses:
        finger = dataclasses.replace(config.finger, skin_texture_response=response)
        for model in models:
            cfg = dataclasses.replace(
                config,
                finger=finger,
                materials=with_friction_model(config.materials, finger, model),
            )
            print(f"== friction model: {model}, skin: {response}")
            print_friction(cfg, speeds, args.force)
            key = model if response == "elastic" else f"{model}+{response}"
            results[key] = report(cfg, speeds, args)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh)
    return 0


if __name__ == "__main__":
    sys.exit(main())
