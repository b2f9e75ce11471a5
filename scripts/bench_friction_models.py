"""The measured friction law beside the derived one, on the paper's datasets.

    python3 scripts/bench_friction_models.py [--out DIR] [--perturbation] [--json PATH]
                                             [--models MODEL ...]
    python3 scripts/bench_friction_models.py --sensitivity

For each contact model (``shared``: one measured law for every material; ``derived``:
each material's law from its surface, ``docs/friction.md``; ``derived+viscoelastic``:
the derived laws and a skin answering the texture with its complex modulus,
``generate --skin-response viscoelastic``; ``--models`` picks some) it generates the paper
preset into ``DIR/paper-MODEL`` (timed: wall seconds in this process), diagnoses it
(leave-one-out 1-NN material accuracy from the strain gauges and from the films, on the
whole window) and runs AFOP-ML's closed-set table (``benchmark closed-set --methods
AFOP-ML``: its 5-way 1-shot and 36-way 1-shot rows, its chosen D and PVDF share). With
``--perturbation`` it also generates the perturbation preset and runs the perturbation
protocol for AFOP-ML (5-way 1-shot: the nominal reference, pooled over the conditions,
within each condition, enrolled at the nominal condition and tested at the others; and
the chosen D). Prints one table, the models side by side. A store already in ``DIR`` of the
same configuration is reused (its generation time is then not measured).

``--sensitivity`` simulates nothing: it prints the derived kinetic coefficient of each
paper material at 10 mm/s and 1 N with each of the skin's three free inputs
(``synth.tribology.SkinTribology``) moved to either end of a plausible range, the others
as shipped, to show what the derived values hang on; then with the shear stress that
makes resin's coefficient each measured one of silicone on printed PLA.

These numbers are consequences of the friction model, reported as they come: the model's
inputs are fixed in ``synth.tribology`` and nothing here chooses them.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

from benchmark.cli import main as cli
from benchmark.diagnose import diagnose
from synth import load_dataset, store

MODELS = ("shared", "derived", "derived+viscoelastic")
#: The benchmark runs: AFOP-ML only, replacing an earlier result in the same place.
AFOP = ("--methods", "AFOP-ML", "--overwrite")


def _run(argv: list[str]) -> None:
    """One ``tactile-synth`` command, its printed output kept quiet; a failure is raised."""
    with contextlib.redirect_stdout(io.StringIO()) as out:
        code = cli(argv)
    if code != 0:
        raise SystemExit(f"tactile-synth {' '.join(argv)} failed:\n{out.getvalue()}")


def _generate(preset: str, model: str, path: Path) -> float | None:
    """Generate ``preset`` under ``model`` at ``path``; wall seconds, or None when a
    complete store is already there."""
    if store.is_store(path):
        done, _ = store.Store.open(path).status()
        if done.all():
            return None
    friction, _, response = model.partition("+")
    skin = ["--skin-response", response] if response else []
    start = time.perf_counter()
    _run(["generate", "--preset", preset, "--friction-model", friction, *skin, "--out", str(path)])
    return time.perf_counter() - start


def _records(path: Path) -> list[dict]:
    return json.loads((path / "results.json").read_text())


def _accuracy(records: list[dict], way: int, shot: int, condition=None) -> float:
    for r in records:
        if (
            r["record"] == "accuracy"
            and r["way"] == way
            and r["shot"] == shot
            and r.get("condition") == condition
        ):
            return float(r["accuracy"])
    raise KeyError(f"no {way}-way {shot}-shot row (condition {condition!r})")


def measure(out: Path, model: str, perturbation: bool) -> dict:
    row: dict = {}
    paper = out / f"paper-{model}"
    row["generate_paper_s"] = _generate("paper", model, paper)
    diag = diagnose(load_dataset(paper), source=str(paper))
    row["material_1nn_sg"] = diag.accuracy["material"]["sg"]
    row["material_1nn_pvdf"] = diag.accuracy["material"]["pvdf"]
    closed = out / f"closed-{model}"
    _run(["benchmark", "closed-set", "--data", str(paper), "--out", str(closed), *AFOP])
    records = _records(closed)
    row["closed_5w1s"] = _accuracy(records, 5, 1)
    row["closed_36w1s"] = _accuracy(records, 36, 1)
    selection = next(r for r in records if r["record"] == "selection")
    row["closed_D"] = selection["D"]
    row["closed_pvdf_share"] = selection["pvdf_share"]
    if perturbation:
        perturbed = out / f"perturbation-{model}"
        row["generate_perturbation_s"] = _generate("perturbation", model, perturbed)
        result = out / f"perturbation-result-{model}"
        data = ["--data", str(paper), "--perturbed", str(perturbed), "--out", str(result)]
        _run(["benchmark", "perturbation", *data, *AFOP])
        records = _records(result)
        row["perturbation_reference_5w1s"] = _accuracy(records, 5, 1, "reference")
        row["perturbation_pooled_5w1s"] = _accuracy(records, 5, 1, "pooled")
        row["perturbation_within_5w1s"] = _accuracy(records, 5, 1, "within-condition")
        row["perturbation_enrolled_5w1s"] = _accuracy(records, 5, 1, "enrolled")
        row["perturbation_D"] = next(r for r in records if r["record"] == "selection")["D"]
    return row


#: The free inputs moved by ``--sensitivity``: (label, field, values).
SENSITIVITY = (
    ("interfacial shear stress (kPa)", "interfacial_shear_stress_pa", (20e3, 100e3, 200e3)),
    ("Prony ratios (times shipped)", "prony", (0.5, 2.0)),
    ("roughness cutoff (um)", "roughness_cutoff_m", (5e-6, 20e-6)),
)


#: Silicone on printed PLA at 10 mm/s near the skin's pressure: the two measured
#: silicones and their middle (the shared law's kinetic coefficient, docs/simulator.md).
PLA_FRICTION = (0.62, 1.15, 1.67)


def sensitivity() -> list[tuple[str, list[float]]]:
    """``(label, [mu per paper material])`` as shipped, then per moved input."""
    import dataclasses

    import synth
    from synth import tribology
    from synth.materials import MATERIALS
    from synth.viscoelastic import PronyTerm

    finger = synth.SynthConfig().finger
    base = tribology.SILICONE_TRIBOLOGY

    def parts(skin: tribology.SkinTribology) -> dict[str, tribology.Friction]:
        return {
            m: tribology.friction(
                MATERIALS[m].texture,
                finger,
                skin,
                speed_m_s=tribology.REFERENCE_SPEED_M_S,
                force_n=1.0,
            )
            for m in synth.MATERIAL_NAMES
        }

    def mus(skin: tribology.SkinTribology) -> list[float]:
        return [f.total for f in parts(skin).values()]

    shipped = parts(base)
    rows = [("as shipped", [f.total for f in shipped.values()])]
    for label, field, values in SENSITIVITY:
        for v in values:
            if field == "prony":
                terms = tuple(PronyTerm(t.ratio * v, t.relaxation_time_s) for t in base.prony)
                skin, shown = dataclasses.replace(base, prony=terms), f"x{v:g}"
            else:
                scale = 1e3 if field.endswith("_pa") else 1e-6
                skin, shown = dataclasses.replace(base, **{field: v}), f"{v / scale:g}"
            rows.append((f"{label} {shown}", mus(skin)))
    # The shear stress read off silicone on printed PLA instead (the low end, the middle
    # and the high end of the two measured silicones), resin's texture standing for PLA's:
    # the stress that makes resin's derived coefficient the measured one.
    resin = shipped["resin"]
    sigma0 = tribology.nominal_pressure_pa(finger, 1.0)
    for mu in PLA_FRICTION:
        tau = (mu - resin.hysteresis) * sigma0 / resin.contact_fraction
        skin = dataclasses.replace(base, interfacial_shear_stress_pa=tau)
        rows.append((f"resin at PLA's {mu:g}: {tau / 1e3:.0f} kPa", mus(skin)))
    return rows


LABELS = {
    "generate_paper_s": ("paper preset generated in (s)", "{:.1f}"),
    "material_1nn_sg": ("material 1-NN, strain gauges", "{:.3f}"),
    "material_1nn_pvdf": ("material 1-NN, films", "{:.3f}"),
    "closed_5w1s": ("AFOP-ML closed set 5-way 1-shot", "{:.2%}"),
    "closed_36w1s": ("AFOP-ML closed set 36-way 1-shot", "{:.2%}"),
    "closed_D": ("AFOP-ML closed set chosen D", "{}"),
    "closed_pvdf_share": ("AFOP-ML closed set PVDF share", "{:.3f}"),
    "generate_perturbation_s": ("perturbation preset generated in (s)", "{:.1f}"),
    "perturbation_reference_5w1s": ("AFOP-ML perturbation: nominal reference", "{:.2%}"),
    "perturbation_pooled_5w1s": ("AFOP-ML perturbation: pooled", "{:.2%}"),
    "perturbation_within_5w1s": ("AFOP-ML perturbation: within condition", "{:.2%}"),
    "perturbation_enrolled_5w1s": ("AFOP-ML perturbation: enrolled at nominal", "{:.2%}"),
    "perturbation_D": ("AFOP-ML perturbation chosen D", "{}"),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="out/friction-models", help="stores and results")
    parser.add_argument(
        "--perturbation", action="store_true", help="also the perturbation protocol"
    )
    parser.add_argument("--json", help="also write the table to this JSON file")
    parser.add_argument(
        "--sensitivity", action="store_true", help="the derived friction's free inputs"
    )
    parser.add_argument(
        "--models", nargs="+", choices=MODELS, default=list(MODELS), help="the columns"
    )
    args = parser.parse_args(argv)
    if args.sensitivity:
        import synth

        print(
            f"{'derived kinetic friction, 10 mm/s, 1 N':<40}"
            + "".join(f"{m:>10}" for m in synth.MATERIAL_NAMES)
        )
        for label, mu in sensitivity():
            print(f"{label:<40}" + "".join(f"{x:>10.3f}" for x in mu))
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    models = list(dict.fromkeys(args.models))
    rows = {}
    for model in models:
        print(f"measuring the {model} contact model ...", file=sys.stderr, flush=True)
        rows[model] = measure(out, model, args.perturbation)
    print(f"{'':<44}" + "".join(f"{m:>22}" for m in models))
    for key, (label, form) in LABELS.items():
        if key not in rows[models[0]]:
            continue
        cells = ["reused" if rows[m][key] is None else form.format(rows[m][key]) for m in models]
        print(f"{label:<44}" + "".join(f"{c:>22}" for c in cells))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
