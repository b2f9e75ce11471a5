"""Choose the tuned hyper-parameters of the feature-based methods on validation data drawn
from the closed-set TRAINING half only, and write them with their evidence.

    python3 scripts/tune.py --data PATH [--seed 0] [--episodes 200] [--write]
    python3 scripts/tune.py --data PATH --quick --out DIR      # a fast smoke run

Nothing of the closed-set test half is read. The training half (the closed-set protocol's
seeded 50:50 per-class split) is split again 50:50 per class into an inner-train part
(methods are fitted on it) and an inner-validation part (validation episodes are drawn
from it), mirroring the closed-set protocol inside the training data. Steps, in order
(each uses the values chosen before it):

1. AFOP-ML ``ncfs_lam_n``: fscnca's lambda by MathWorks' documented cross-validation on
   the whole training half (stratified 5 folds, lambda in ``linspace(0, 20, 20) / n``,
   fits capped at 30 L-BFGS iterations as in MathWorks' example, misclassification rate
   of the NCA classifier on the held-out fold, lowest mean wins); stored as lambda * n,
   the form that carries over to training sets of other sizes. The longest step: its
   finished lambdas are kept in ``--cache`` and a rerun resumes.
2. AFOP-ML ``ncfs_max_iter`` (L-BFGS iterations of the NCA fit): for each candidate, the
   feature selection (z-scoring, NCA, D-scan) fitted on inner-train; score = accuracy of
   the plain cosine prototype classifier (the D-scan's own criterion, no adaptation) on the
   top-D features over the validation columns. Rule: the smallest count whose score is
   within the 95 % CI of the best score (the cheapest fit that validation cannot tell apart
   from the best; the NCA fit dominates AFOP-ML's pretrain time).
3. AFOP-ML ``alpha`` (the head's temperature; the paper does not state it): the adapted
   head's validation score; highest mean wins (the first candidate on ties).
4. Direct-Prot-ML ``alpha``: the same for its head on all 386 features.
5. AFO-MLP-ML ``alpha`` (the paper's method: a fresh MLP + head trained per episode):
   each candidate fitted anew on inner-train (alpha enters the per-episode training, whose
   steps and rate the fit chooses on its own validation episodes); highest mean wins.
6. CWT-ResNet-ML ``alpha``: one fit on the inner-train signals (alpha enters only the
   head); highest mean wins.
7. AFO-MLP-ML+meta (the variant beyond the paper) ``meta_lr`` x ``meta_iterations`` (with
   alpha from step 3): validation score of the adapted MLP + head; the shortest
   meta-training within the 95 % CI of the best wins (candidates ordered by length, then
   rate). Then its ``alpha``, each candidate meta-trained anew (alpha also scales the
   meta-training logits); highest mean wins.

Validation columns: 5-way-1-shot, 5-way-5-shot and all-classes-way-1-shot (queries per
class lowered to what inner-validation holds), ``--episodes`` episodes each, the same
episodes for every candidate; score = mean of the column means, its CI =
``sqrt(sum ci_c^2) / C``. With ``--write`` the chosen values go to ``models/tuned.json``
(the defaults the methods load) and the evidence to ``docs/tuning.md`` and
``docs/tuning.json``; otherwise to ``--out DIR``. Same data and seed give the same files.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tactile_synth.validation import int_arg

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmark.evaluate import ci95  # noqa: E402
from benchmark.protocols.closed_set import split_halves  # noqa: E402
from benchmark.tasks import child_seed  # noqa: E402
from models.afo_mlp import AFOMLPML, AFOMLPMLMeta  # noqa: E402
from models.afop import AFOPML  # noqa: E402
from models.cwt_resnet import CWTResNetML  # noqa: E402
from models.direct_prot import DirectProtML  # noqa: E402
from models.dscan import dscan  # noqa: E402
from models.episodes import EpisodeBatch, sample_episodes  # noqa: E402
from models.ncfs import NCFS, LambdaCV, select_lambda  # noqa: E402
from models.prototypes import nearest_prototype  # noqa: E402
from models.scaling import FeatureScaler  # noqa: E402

ALPHAS: tuple[float, ...] = (5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 50.0, 75.0, 100.0, 150.0, 200.0)
MAX_ITERS: tuple[int, ...] = (5, 10, 15, 20, 30, 50, 100)
#: L-BFGS iterations of the fits inside the lambda cross-validation (step 1), as in
#: MathWorks' fscnca tuning example (IterationLimit 30).
CV_MAX_ITER: int = 30
META_LRS: tuple[float, ...] = (3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1)
META_ITERATIONS: tuple[int, ...] = (100, 300, 1000, 3000)
QUICK = {
    "alphas": (5.0, 10.0, 20.0),
    "max_iters": (5, 20),
    "lam_grid": 4,
    "cv_max_iter": 20,
    "meta_lrs": (1e-3,),
    "meta_iterations": (20, 60),
    "cwt": {"max_epochs": 2, "val_episodes": 20},
}

#: Trials per class the data need: a 5-fold CV of the training half, and inner-train /
#: inner-validation halves that hold 1-shot episodes with a query.
MIN_TRIALS_PER_CLASS: int = 10

RULE_BEST = "highest mean validation score (first candidate on ties)"
RULE_CHEAPEST = "smallest candidate whose score is within the 95 % CI of the best score"
RULE_CV = "lowest mean cross-validated NCA misclassification rate (first candidate on ties)"


# -- selection rules (also re-applied by the tests to the committed evidence) ---------------
def choose_best(scores: Sequence[float]) -> int:
    """Index of the highest score (the first on ties)."""
    return int(np.argmax(np.asarray(scores, dtype=float)))


def choose_cheapest_within_ci(scores: Sequence[float], cis: Sequence[float]) -> int:
    """Index of the first (cheapest) candidate whose score is >= best - CI(best)."""
    s = np.asarray(scores, dtype=float)
    b = int(np.argmax(s))
    return int(np.flatnonzero(s >= s[b] - float(cis[b]))[0])


def choose_lowest(losses: Sequence[float]) -> int:
    """Index of the lowest loss (the first on ties)."""
    return int(np.argmin(np.asarray(losses, dtype=float)))


RULES: dict[str, Callable[..., int]] = {
    RULE_BEST: lambda step: choose_best(step["score"]),
    RULE_CHEAPEST: lambda step: choose_cheapest_within_ci(step["score"], step["ci95"]),
    RULE_CV: lambda step: choose_lowest(step["score"]),
}


def apply_rule(step: dict[str, Any]) -> Any:
    """The candidate a step's rule picks from its recorded scores."""
    return step["candidates"][RULES[step["rule"]](step)]


# -- validation episodes -------------------------------------------------------------------
def validation_batches(labels: np.ndarray, episodes: int, seed: int) -> list[EpisodeBatch]:
    """5-way-1-shot, 5-way-5-shot and all-way-1-shot episodes over ``labels`` (the
    inner-validation trials), queries per class lowered to what the smallest class holds;
    columns the pool cannot hold are left out."""
    n_classes = np.unique(labels).size
    smallest = int(np.unique(labels, return_counts=True)[1].min())
    out = []
    for shot, way in ((1, 5), (5, 5), (1, n_classes)):
        way = min(way, n_classes)
        query = min(5, smallest - shot)
        if way < 2 or query < 1:
            continue
        out.append(
            sample_episodes(
                labels,
                n_way=way,
                k_shot=shot,
                n_query=query,
                episodes=episodes,
                seed=child_seed(seed, "tune", shot, way),
            )
        )
    if not out:
        raise ValueError("the inner-validation trials cannot hold any validation column")
    return out


def score(predict: Callable[[EpisodeBatch], np.ndarray], batches: Sequence[EpisodeBatch]):
    """(score, ci95, per-column means): mean over columns of the mean episode accuracy."""
    means, cis = [], []
    for b in batches:
        acc = (predict(b) == b.query_labels).mean(axis=1)
        means.append(float(acc.mean()))
        cis.append(ci95(acc))
    return (
        float(np.mean(means)),
        float(np.sqrt(np.sum(np.square(cis))) / len(cis)),
        [round(m, 6) for m in means],
    )


def _column_names(batches: Sequence[EpisodeBatch]) -> list[str]:
    return [f"{b.k_shot}-shot {b.n_way}-way" for b in batches]


# -- the steps -----------------------------------------------------------------------------
def _step(method: str, parameter: str, rule: str, criterion: str) -> dict[str, Any]:
    return {
        "method": method,
        "parameter": parameter,
        "rule": rule,
        "criterion": criterion,
        "candidates": [],
        "score": [],
        "ci95": [],
        "columns": [],
    }


def _log(msg: str) -> None:
    print(f"[tune] {msg}", flush=True)


def _cached_lambda_cv(
    z: np.ndarray,
    y: np.ndarray,
    grid: np.ndarray,
    seed: int,
    max_iter: int,
    cache: Path | None,
) -> LambdaCV:
    """:func:`select_lambda` one lambda at a time (the folds depend only on the seed), each
    lambda's fold losses saved under ``cache`` so an interrupted run resumes."""
    key = hashlib.sha256(
        np.ascontiguousarray(z).tobytes()
        + np.ascontiguousarray(y).tobytes()
        + json.dumps([seed, max_iter]).encode()
    ).hexdigest()[:16]
    path = None if cache is None else cache / f"lambda-cv-{key}.json"
    done: dict[str, list[float]] = {}
    if path is not None and path.is_file():
        done = json.loads(path.read_text())
    rows = []
    for lam in grid:
        name = repr(float(lam))
        if name not in done:
            cv = select_lambda(z, y, lambdas=[lam], seed=seed, max_iter=max_iter)
            done[name] = [float(v) for v in cv.fold_loss[0]]
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                tmp = path.with_suffix(".tmp")
                tmp.write_text(json.dumps(done))
                tmp.replace(path)
        rows.append(done[name])
        _log(f"  lambda = {lam:.4g} ({lam * len(y):.2f}/n): CV loss {np.mean(done[name]):.4f}")
    loss = np.asarray(rows)
    mean = loss.mean(axis=1)
    return LambdaCV(
        lambdas=np.asarray(grid), fold_loss=loss, mean_loss=mean, best=float(grid[np.argmin(mean)])
    )


def tune(
    features: np.ndarray,
    labels: np.ndarray,
    signals: np.ndarray,
    *,
    seed: int = 0,
    episodes: int = 200,
    quick: bool = False,
    cache: Path | None = None,
) -> tuple[dict[str, dict[str, Any]], list[dict[str, Any]]]:
    """Run every step on the closed-set training half of (features, labels, signals)
    (``signals``: ``(n, 4, T)`` raw trials, for CWT-ResNet-ML).

    ``cache``: a directory where the lambda cross-validation (the long step) keeps its
    finished results, so an interrupted run resumes. Returns (chosen values
    ``{method: {parameter: value}}``, evidence steps)."""
    grids = (
        QUICK
        if quick
        else {
            "alphas": ALPHAS,
            "max_iters": MAX_ITERS,
            "lam_grid": 20,
            "cv_max_iter": CV_MAX_ITER,
            "meta_lrs": META_LRS,
            "meta_iterations": META_ITERATIONS,
            "cwt": {},
        }
    )
    smallest = int(np.unique(labels, return_counts=True)[1].min())
    if smallest < MIN_TRIALS_PER_CLASS:
        raise ValueError(
            f"tuning needs >= {MIN_TRIALS_PER_CLASS} trials per class (the closed-set "
            "training half is halved again and cross-validated 5-fold); the data has "
            f"{smallest} for some class"
        )
    train, _ = split_halves(labels, seed=seed)  # the test half is never used
    y_tr = labels[train]
    f_tr = features[train]
    i_fit, i_val = split_halves(y_tr, seed=child_seed(seed, "tune-inner"))
    f_fit, y_fit = f_tr[i_fit], y_tr[i_fit]
    f_val, y_val = f_tr[i_val], y_tr[i_val]
    s_tr = np.asarray(signals)[train]
    s_fit, s_val = s_tr[i_fit], s_tr[i_val]
    no_signals = np.zeros((len(f_tr), 1, 1), np.float32)  # the feature methods read features
    batches = validation_batches(y_val, episodes, seed)
    columns = _column_names(batches)
    chosen: dict[str, dict[str, Any]] = {
        "AFOP-ML": {},
        "Direct-Prot-ML": {},
        "AFO-MLP-ML": {},
        "CWT-ResNet-ML": {},
        "AFO-MLP-ML+meta": {},
    }
    steps: list[dict[str, Any]] = []
    _log(
        f"training half {len(train)} trials: inner-train {len(i_fit)}, inner-validation "
        f"{len(i_val)}; columns {', '.join(columns)} x {episodes} episodes"
    )

    def predictor(
        model: Any, signals: np.ndarray | None = None
    ) -> Callable[[EpisodeBatch], np.ndarray]:
        pool = no_signals[: len(f_val)] if signals is None else signals
        return lambda b: model.predict_episodes(pool, b.support, b.query, features=f_val)

    # 1. fscnca lambda by cross-validation on the whole training half.
    t0 = time.perf_counter()
    z_tr = FeatureScaler().fit_transform(f_tr)
    n = len(train)
    grid = np.linspace(0.0, 20.0, grids["lam_grid"]) / n
    _log(f"step 1: fscnca lambda, {grid.size} values x 5 folds on {n} trials")
    cv = _cached_lambda_cv(z_tr, y_tr, grid, seed, grids["cv_max_iter"], cache)
    st = _step(
        "AFOP-ML",
        "ncfs_lam_n",
        RULE_CV,
        f"5-fold stratified CV on the {n}-trial training half; NCA classifier "
        f"misclassification rate; fits capped at {grids['cv_max_iter']} L-BFGS "
        "iterations; candidates are lambda * n",
    )
    st["candidates"] = [round(float(v * n), 6) for v in cv.lambdas]
    st["score"] = [float(v) for v in cv.mean_loss]
    st["ci95"] = [ci95(v) for v in cv.fold_loss]
    st["columns"] = [[float(x) for x in row] for row in cv.fold_loss]
    st["seconds"] = round(time.perf_counter() - t0, 1)
    lam_n = apply_rule(st)
    chosen["AFOP-ML"]["ncfs_lam_n"] = lam_n
    steps.append(st)
    _log(f"step 1: ncfs_lam_n = {lam_n}")

    # 2. L-BFGS iterations of the NCA fit (snapshots of one run: identical to fresh fits).
    t0 = time.perf_counter()
    scaler = FeatureScaler().fit(f_fit)
    z_fit, z_val = scaler.transform(f_fit), scaler.transform(f_val)
    snaps: dict[int, np.ndarray] = {}
    max_iters = tuple(grids["max_iters"])
    NCFS(lam=lam_n / len(y_fit), max_iter=max(max_iters)).fit(
        z_fit, y_fit, on_iteration=lambda k, w: snaps.__setitem__(k, w.copy())
    )
    last = max(snaps)
    st = _step(
        "AFOP-ML",
        "ncfs_max_iter",
        RULE_CHEAPEST,
        "feature selection fitted on inner-train; cosine prototype classifier "
        "(no adaptation) on the top-D features, D by the D-scan",
    )
    st["D"] = []
    for m in max_iters:
        w = snaps[min(m, last)]  # a fit that converged earlier stops there
        ranking = np.lexsort((np.arange(w.size), -w))
        d = dscan(z_fit, y_fit, ranking, seed=seed).best
        s, c, cols = score(
            lambda b, r=ranking, d=d: nearest_prototype(z_val[:, r[:d]], b.support, b.query),
            batches,
        )
        st["candidates"].append(m)
        st["score"].append(s)
        st["ci95"].append(c)
        st["columns"].append(cols)
        st["D"].append(int(d))
        _log(f"  ncfs_max_iter {m}: D {d}, score {s:.4f} ± {c:.4f}")
    st["converged_at"] = int(last)
    st["seconds"] = round(time.perf_counter() - t0, 1)
    max_iter = apply_rule(st)
    chosen["AFOP-ML"]["ncfs_max_iter"] = int(max_iter)
    steps.append(st)
    _log(f"step 2: ncfs_max_iter = {max_iter}")

    # 3. AFOP-ML alpha (one fit: alpha only enters the episodic head).
    def alpha_step(
        method: str,
        model_for: Callable[[float], Any],
        criterion: str,
        signals: np.ndarray | None = None,
    ) -> float:
        t0 = time.perf_counter()
        st = _step(method, "alpha", RULE_BEST, criterion)
        for a in grids["alphas"]:
            s, c, cols = score(predictor(model_for(a), signals), batches)
            st["candidates"].append(a)
            st["score"].append(s)
            st["ci95"].append(c)
            st["columns"].append(cols)
            _log(f"  {method} alpha {a}: score {s:.4f} ± {c:.4f}")
        st["seconds"] = round(time.perf_counter() - t0, 1)
        steps.append(st)
        value = apply_rule(st)
        _log(f"{method}: alpha = {value}")
        return float(value)

    def refit_alpha(model: Any) -> Callable[[float], Any]:
        def with_alpha(a: float) -> Any:
            model.alpha = a  # the fitted state does not depend on alpha
            return model

        return with_alpha

    head = "adapted head on inner-validation episodes (one fit; alpha enters only the head)"
    afop = AFOPML(seed=seed, alpha=1.0, ncfs_lam_n=lam_n, ncfs_max_iter=max_iter)
    afop.fit(no_signals[: len(f_fit)], y_fit, features=f_fit)
    chosen["AFOP-ML"]["alpha"] = alpha_step("AFOP-ML", refit_alpha(afop), head)

    # 4. Direct-Prot-ML alpha.
    direct = DirectProtML(seed=seed, alpha=1.0).fit(no_signals[: len(f_fit)], y_fit, features=f_fit)
    chosen["Direct-Prot-ML"]["alpha"] = alpha_step("Direct-Prot-ML", refit_alpha(direct), head)

    # 5. AFO-MLP-ML (the paper's): every alpha a new fit (it enters the per-episode training
    # and the fit's choice of its steps and rate).
    def afo_mlp_paper(alpha: float) -> AFOMLPML:
        model = AFOMLPML(seed=seed, alpha=alpha, ncfs_lam_n=lam_n, ncfs_max_iter=max_iter)
        return model.fit(no_signals[: len(f_fit)], y_fit, features=f_fit)

    chosen["AFO-MLP-ML"]["alpha"] = alpha_step(
        "AFO-MLP-ML",
        afo_mlp_paper,
        "fresh MLP + head trained per episode on inner-validation episodes; each alpha "
        "fitted anew (its steps and rate chosen by the fit on inner-train)",
    )

    # 6. CWT-ResNet-ML: one fit on the inner-train signals.
    cwt = CWTResNetML(seed=seed, alpha=1.0, **grids["cwt"]).fit(s_fit, y_fit)
    chosen["CWT-ResNet-ML"]["alpha"] = alpha_step(
        "CWT-ResNet-ML",
        refit_alpha(cwt),
        "adapted head on the ResNet embeddings of inner-validation episodes (one fit on "
        "the inner-train signals; alpha enters only the head)",
        signals=s_val,
    )

    # 7. AFO-MLP-ML+meta meta-training (candidates in order of meta-training length), then
    # its alpha, which also enters meta-training, so every alpha is a new fit.
    def afo_mlp(lr: float, its: int, alpha: float) -> AFOMLPMLMeta:
        model = AFOMLPMLMeta(
            seed=seed,
            alpha=alpha,
            meta_lr=lr,
            meta_iterations=its,
            ncfs_lam_n=lam_n,
            ncfs_max_iter=max_iter,
        )
        return model.fit(no_signals[: len(f_fit)], y_fit, features=f_fit)

    t0 = time.perf_counter()
    alpha0 = chosen["AFOP-ML"]["alpha"]
    st = _step(
        "AFO-MLP-ML+meta",
        "meta_lr, meta_iterations",
        RULE_CHEAPEST,
        f"adapted MLP + head on inner-validation episodes, alpha = {alpha0} (AFOP-ML's); "
        "candidates ordered by meta-training length",
    )
    for its in grids["meta_iterations"]:
        for lr in grids["meta_lrs"]:
            s, c, cols = score(predictor(afo_mlp(lr, its, alpha0)), batches)
            st["candidates"].append([lr, its])
            st["score"].append(s)
            st["ci95"].append(c)
            st["columns"].append(cols)
            _log(f"  AFO-MLP-ML+meta meta_lr {lr} meta_iterations {its}: score {s:.4f} ± {c:.4f}")
    st["seconds"] = round(time.perf_counter() - t0, 1)
    steps.append(st)
    lr, its = apply_rule(st)
    chosen["AFO-MLP-ML+meta"]["meta_lr"] = float(lr)
    chosen["AFO-MLP-ML+meta"]["meta_iterations"] = int(its)
    chosen["AFO-MLP-ML+meta"]["alpha"] = alpha_step(
        "AFO-MLP-ML+meta",
        lambda a: afo_mlp(lr, its, a),
        "adapted MLP + head on inner-validation episodes; each alpha meta-trained anew",
    )
    for step in steps:
        step["column_names"] = (
            columns
            if step["rule"] != RULE_CV
            else [f"fold {k}" for k in range(len(step["columns"][0]))]
        )
    return chosen, steps


# -- output --------------------------------------------------------------------------------
def _fmt(v: Any) -> str:
    if isinstance(v, list):
        return ", ".join(_fmt(x) for x in v)
    return f"{v:g}" if isinstance(v, float) else str(v)


#: The page's first section: how every hyper-parameter is chosen (the same on every run).
MODEL_SELECTION: tuple[str, ...] = (
    "## How the values are chosen",
    "",
    "Every hyper-parameter of the feature-based methods is either the paper's value (the "
    "episodic head's 250 Adam steps at lr 1.5e-3 with entropy weight 0.10, the D-scan's "
    "5-way-5-shot validation episodes, the 64/32 MLP widths), a default of the cited "
    "algorithm (MATLAB `fscnca`'s kernel width 1 and initial weights 1), or chosen on "
    "validation data drawn from the closed-set **training** half only by `scripts/tune.py`, "
    "which writes the values to `models/tuned.json` (what the methods use by default) and "
    "every candidate's validation score with its 95 % CI to this page:",
    "",
    "```bash",
    "PYTHONPATH=$PWD python3 scripts/tune.py --data data/paper --write",
    "```",
    "",
    "It chooses fscnca's lambda by MathWorks' documented 5-fold cross-validation, the NCA "
    "fit's L-BFGS iterations, the heads' temperature `alpha` (not given in the paper) and "
    "AFO-MLP-ML's meta-training rate and length; the test half is never read (a test "
    "poisons it and checks the choices do not move). Same data and seed give the same "
    "files; the lambda cross-validation keeps finished results in `--cache`, so an "
    "interrupted run resumes. Rerun it when the simulator changes.",
)


def evidence_markdown(meta: dict[str, Any], chosen: dict, steps: list[dict]) -> str:
    lines = [
        "# Tuned hyper-parameters and their evidence",
        "",
        *MODEL_SELECTION,
        "",
        "## The evidence",
        "",
        f"Generated by `{meta['command']}` (do not edit by hand). Data: {meta['data']}. "
        f"Seed {meta['seed']}; {meta['episodes']} validation episodes per column.",
        "",
        "Only the closed-set training half is used: methods are fitted on one half of it "
        "(inner-train) and scored on validation episodes drawn from the other half "
        "(inner-validation); the lambda cross-validation runs on the whole training half. "
        "The closed-set test half is never read. Scores are mean accuracies (fractions) "
        "over the validation columns with their 95 % CI; the lambda step's score is the "
        "cross-validated misclassification rate (lower is better).",
        "",
        "Values every method uses that are not tuned here: the paper's head settings "
        "(250 Adam steps, lr 1.5e-3, entropy weight 0.10), the paper's 5-way-5-shot D-scan "
        "validation episodes, the paper's 64/32 MLP widths, fscnca's kernel width 1 and "
        "initial weights 1; AFO-MLP-ML+meta's 16 tasks per meta-step is a fixed compute "
        "budget. AFO-MLP-ML's per-episode steps and rate, and CWT-ResNet-ML's epochs, are "
        "chosen inside each fit on its own training data.",
        "",
        "## Chosen values",
        "",
        "| method | parameter | value |",
        "|---|---|---|",
    ]
    for m, params in chosen.items():
        for k, v in params.items():
            lines.append(f"| {m} | `{k}` | {_fmt(v)} |")
    for st in steps:
        lines += [
            "",
            f"## {st['method']}: `{st['parameter']}`",
            "",
            f"Criterion: {st['criterion']}. Rule: {st['rule']}. "
            f"Chosen: **{_fmt(apply_rule(st))}** ({st['seconds']} s).",
            "",
        ]
        extra = ["D"] if "D" in st else []
        header = ["candidate", "score", "95 % CI", *st["column_names"], *extra]
        lines.append("| " + " | ".join(header) + " |")
        lines.append("|" + "---|" * len(header))
        for i, cand in enumerate(st["candidates"]):
            row = [
                _fmt(cand),
                f"{st['score'][i]:.4f}",
                f"± {st['ci95'][i]:.4f}",
                *[f"{x:.4f}" for x in st["columns"][i]],
                *([str(st["D"][i])] if extra else []),
            ]
            lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="dataset (e.g. the paper preset)")
    parser.add_argument("--seed", type=int_arg, default=0, help="closed-set split and episode seed")
    parser.add_argument("--episodes", type=int_arg, default=200, help="episodes per column")
    parser.add_argument("--quick", action="store_true", help="coarse grids (smoke test)")
    parser.add_argument(
        "--write",
        action="store_true",
        help="write models/tuned.json, docs/tuning.md and docs/tuning.json",
    )
    parser.add_argument("--out", help="directory for the three files (instead of --write)")
    parser.add_argument(
        "--cache",
        default=str(Path.home() / ".cache" / "tactile-synth" / "tune"),
        help="where finished lambda-CV results are kept so a rerun resumes (default %(default)s)",
    )
    args = parser.parse_args(argv)
    if args.write == bool(args.out):
        parser.error("give exactly one of --write or --out DIR")
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1; got {args.episodes}")
    from benchmark.run import dataset_summary
    from models.features import extract
    from synth import load_dataset

    data = load_dataset(args.data)
    counts = np.unique(data.label, return_counts=True)[1]
    if counts.min() < MIN_TRIALS_PER_CLASS:
        parser.error(
            f"--data {args.data}: tuning needs >= {MIN_TRIALS_PER_CLASS} trials per class; "
            f"it has {counts.min()}"
        )
    t0 = time.perf_counter()
    _log(f"extracting the 386-feature pool of {len(data)} trials")
    features = extract(data.signals)
    chosen, steps = tune(
        features,
        data.label,
        data.signals,
        seed=args.seed,
        episodes=args.episodes,
        quick=args.quick,
        cache=Path(args.cache),
    )
    command = (
        "python3 scripts/tune.py --data PATH"
        + (f" --seed {args.seed}" if args.seed else "")
        + (f" --episodes {args.episodes}" if args.episodes != 200 else "")
        + (" --quick" if args.quick else "")
        + " --write"
    )
    meta = {
        "command": command,
        "data": dataset_summary(data, None),
        "seed": args.seed,
        "episodes": args.episodes,
    }
    if args.write:
        values_path = ROOT / "models" / "tuned.json"
        docs = ROOT / "docs"
    else:
        values_path = Path(args.out) / "tuned.json"
        docs = Path(args.out)
    docs.mkdir(parents=True, exist_ok=True)
    values_path.write_text(json.dumps({**meta, "values": chosen}, indent=1) + "\n")
    (docs / "tuning.json").write_text(json.dumps({**meta, "steps": steps}, indent=1) + "\n")
    (docs / "tuning.md").write_text(evidence_markdown(meta, chosen, steps))
    _log(f"done in {time.perf_counter() - t0:.0f} s: {values_path}, {docs / 'tuning.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
