"""``tactile-synth calibrate``: fit the twin's global physical parameters to a lab's
recordings by simulation-based inference.

The method is neural posterior estimation (NPE, the ``sbi`` library): the calibration
draws ``budget`` parameter vectors from the prior (uniform over each parameter's cited
range, log-uniform where it spans ten times or more; a scrambled Halton sequence, so the
draws cover the box evenly), simulates the recordings' classes and conditions at each
(:func:`benchmark.twin.world.simulate`), summarises every simulation as the recordings
are summarised (:mod:`benchmark.twin.summaries`), trains a conditional density estimator
of the parameters given the summaries, and reads the posterior at the recordings'
summary. The posterior is amortised: the same simulations give the posterior of any
recordings of the same classes and conditions, which is what lets the calibration check
itself on stores of known parameters (``scripts/bench_calibrate.py``).

Every simulation is saved to ``DIR/simulations.npz`` as it finishes, so an interrupted
calibration resumes with ``--resume`` and simulates only what is missing; a simulation's
trials depend only on the seed and its index, so the results are the same in this
process, in worker processes or on a Dask cluster.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import io
import json
import multiprocessing
import os
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from synth.calibration.parameters import PARAMETERS, Parameter
from synth.calibration.settings import CalibrationError

from .result import Calibration, Estimate
from .world import World, simulate, summary_size, world_of

#: The parameters a calibration fits unless ``--parameters`` names others: the films'
#: readout (post-gain, charge-amplifier corner), the gauges' amplifier gain, the mains
#: pickup, the surfaces' texture scale and the robot's stroke-to-stroke force scatter.
DEFAULT_PARAMETERS = (
    "pvdf.post_gain",
    "pvdf.feedback_resistance_ohm",
    "strain_gauge.amplifier_gain",
    "acquisition.mains_v",
    "materials.texture_scale",
    "variability.force_rel",
)
#: Simulations by default, and trials per class and condition in each.
DEFAULT_BUDGET = 300
DEFAULT_TRIALS_PER_CLASS = 2
#: Simulations per gradient step of the posterior's training: a few hundred simulations
#: then give some ten steps per epoch (sbi's default batch of 200 would give one, and
#: its early stopping would end the training long before the flow fits).
TRAINING_BATCH = 25
#: Trainings of the posterior from different initialisations; the one with the best
#: held-out loss (sbi's validation simulations) is kept. A flow trained on a few hundred
#: simulations now and then stops near its start, a posterior as wide as the prior.
RESTARTS = 3
#: Posterior draws the report's intervals are read from.
POSTERIOR_SAMPLES = 4000
#: A parameter whose 90 % posterior interval covers more than this share of its range is
#: reported as not pinned down by the recordings (the prior's own covers 0.9).
FLAT_SHARE = 2 / 3
STATE_FILE, SIMULATIONS_FILE = "state.json", "simulations.npz"


def default_parameters() -> list[Parameter]:
    return [PARAMETERS[n] for n in DEFAULT_PARAMETERS]


def draws(n: int, dims: int, seed: int) -> np.ndarray:
    """The first ``n`` prior draws of a calibration in the unit cube ``(n, dims)``: a
    scrambled Halton sequence of ``seed`` (the first ``n`` are the same for any larger
    budget, so a resumed calibration with a larger budget keeps its simulations)."""
    from scipy.stats import qmc

    return qmc.Halton(d=dims, scramble=True, seed=seed).random(n)


def physical(parameters: Sequence[Parameter], unit: np.ndarray) -> np.ndarray:
    """Unit-cube rows as physical values, column by column."""
    unit = np.atleast_2d(unit)
    return np.array(
        [[p.from_unit(float(u)) for p, u in zip(parameters, row, strict=True)] for row in unit]
    )


# -- the simulations, resumable --------------------------------------------------------------
@dataclasses.dataclass
class Simulations:
    """The prior draws (unit cube) and the summaries simulated for them (NaN rows: not
    simulated yet, or the physics failed: ``failed`` tells which)."""

    unit: np.ndarray
    x: np.ndarray
    done: np.ndarray
    failed: np.ndarray

    def save(self, path: Path) -> None:
        tmp = path.with_name(path.name + ".tmp.npz")
        np.savez(tmp, unit=self.unit, x=self.x, done=self.done, failed=self.failed)
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: Path) -> Simulations:
        with np.load(path, allow_pickle=False) as z:
            return cls(z["unit"], z["x"], z["done"], z["failed"])


def _simulate_task(
    world: World,
    parameters: Sequence[Parameter],
    values: Sequence[float],
    trials_per_class: int,
    seed: int,
    index: int,
    threads: int,
) -> tuple[int, np.ndarray]:
    from tactile_synth.threads import init_worker

    init_worker(threads)
    x = simulate(
        world,
        parameters,
        values,
        trials_per_class=trials_per_class,
        seed=seed,
        index=index,
        threads=threads,
    )
    return index, x


def run_simulations(
    world: World,
    parameters: Sequence[Parameter],
    sims: Simulations,
    *,
    trials_per_class: int,
    seed: int,
    workers: int = 1,
    executor: cf.Executor | None = None,
    save: Path | None = None,
    progress: bool = True,
) -> Simulations:
    """Simulate every draw of ``sims`` not done yet, saving after each (to ``save``)."""
    from synth.progress import progress as show_progress
    from tactile_synth.threads import rollout_threads, worker_threads

    todo = [int(i) for i in np.flatnonzero(~sims.done)]
    bar = show_progress(
        len(sims.done),
        desc="calibrate: simulate",
        unit="simulation",
        initial=int(sims.done.sum()),
        enabled=progress,
    )
    values = physical(parameters, sims.unit)

    def record(index: int, x: np.ndarray) -> None:
        sims.x[index] = x
        sims.failed[index] = bool(np.isnan(x).all())
        sims.done[index] = True
        if save is not None:
            sims.save(save)
        bar.update(1)

    owned = None
    try:
        if executor is None and workers <= 1:
            threads = rollout_threads()
            for i in todo:
                record(
                    i,
                    simulate(
                        world,
                        parameters,
                        values[i],
                        trials_per_class=trials_per_class,
                        seed=seed,
                        index=i,
                        threads=threads,
                    ),
                )
            return sims
        if executor is None:
            ctx = multiprocessing.get_context("spawn")
            threads = worker_threads(workers)
            owned = executor = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        else:
            threads = 1
        pending = {
            executor.submit(
                _simulate_task,
                world,
                list(parameters),
                list(values[i]),
                trials_per_class,
                seed,
                i,
                threads,
            )
            for i in todo
        }
        for fut in cf.as_completed(pending):
            index, x = fut.result()
            record(index, np.asarray(x, dtype=float))
        return sims
    except BaseException:
        if owned is not None:
            owned.shutdown(wait=False, cancel_futures=True)
            owned = None
        raise
    finally:
        bar.close()
        if owned is not None:
            owned.shutdown(wait=True)


# -- the posterior ----------------------------------------------------------------------------
@dataclasses.dataclass
class Posterior:
    """A trained NPE posterior over the unit cube and the summary columns it reads."""

    estimator: Any
    columns: np.ndarray
    n_train: int

    def sample(self, x_obs: np.ndarray, n: int, seed: int) -> np.ndarray:
        import torch

        torch.manual_seed(seed)
        x = torch.as_tensor(x_obs[self.columns], dtype=torch.float32)
        with torch.no_grad():
            s = self.estimator.sample((n,), x=x, show_progress_bars=False)
        return np.clip(s.numpy().astype(float), 0.0, 1.0)


def train_posterior(
    unit: np.ndarray, x: np.ndarray, *, seed: int, usable: np.ndarray | None = None
) -> Posterior:
    """NPE (``sbi``'s masked autoregressive flow, its default) of the unit-cube parameters
    given the summaries: the simulations whose summaries are all finite in the columns
    that are finite in ``usable`` (every column if not given) and vary between
    simulations."""
    import torch
    from sbi.inference import NPE
    from sbi.utils import BoxUniform

    rows = ~np.isnan(x).all(axis=1)
    cols = np.isfinite(x[rows]).all(axis=0)
    if usable is not None:
        cols &= np.isfinite(usable)
    with warnings.catch_warnings():  # an all-NaN column has no spread: it is left out
        warnings.simplefilter("ignore", RuntimeWarning)
        cols &= np.nan_to_num(np.nanstd(x[rows], axis=0)) > 1e-9
    rows &= np.isfinite(x[:, cols]).all(axis=1)
    if rows.sum() < 20:
        raise CalibrationError(
            f"--budget: only {int(rows.sum())} simulations are usable; at least 20 are "
            "needed to train the posterior (raise the budget)"
        )
    d = unit.shape[1]
    prior = BoxUniform(torch.zeros(d), torch.ones(d))
    theta = torch.as_tensor(unit[rows], dtype=torch.float32)
    xs = torch.as_tensor(x[rows][:, cols], dtype=torch.float32)
    best = None
    for restart in range(RESTARTS):
        torch.manual_seed(seed * RESTARTS + restart)
        inference = NPE(prior=prior, show_progress_bars=False, tracker=_NoTracker())
        inference.append_simulations(theta, xs)
        with contextlib.redirect_stdout(io.StringIO()):  # sbi prints its convergence
            estimator = inference.train(
                training_batch_size=TRAINING_BATCH, show_train_summary=False
            )
        loss = float(inference._summary["best_validation_loss"][-1])
        if best is None or loss < best[0]:
            best = (loss, inference, estimator)
    _, inference, estimator = best
    return Posterior(inference.build_posterior(estimator), np.flatnonzero(cols), int(rows.sum()))


class _NoTracker:
    """sbi's tracking protocol doing nothing: its default writes TensorBoard logs into
    the working directory, which a calibration has no use for."""

    log_dir = None

    def log_metric(self, name: str, value: float, step: int | None = None) -> None:
        pass

    def log_metrics(self, metrics: dict, step: int | None = None) -> None:
        pass

    def log_params(self, params: dict) -> None:
        pass

    def add_figure(self, name: str, figure: Any, step: int | None = None) -> None:
        pass

    def flush(self) -> None:
        pass


def estimates(parameters: Sequence[Parameter], samples: np.ndarray) -> list[Estimate]:
    out = []
    for j, p in enumerate(parameters):
        q05, q50, q95 = np.quantile(samples[:, j], [0.05, 0.5, 0.95])
        out.append(
            Estimate(
                p.name,
                p.from_unit(q50),
                p.from_unit(q05),
                p.from_unit(q95),
                p.low,
                p.high,
                flat=bool(q95 - q05 > FLAT_SHARE),
            )
        )
    return out


# -- the command ----------------------------------------------------------------------------
def _state(
    recordings: Any, parameters: Sequence[Parameter], trials_per_class: int, seed: int
) -> dict:
    return {
        "recordings": recordings,
        "parameters": [[p.name, p.low, p.high] for p in parameters],
        "trials_per_class": trials_per_class,
        "seed": seed,
    }


def _prepare_out(
    out: Path, state: dict, budget: int, dims: int, n_x: int, *, resume: bool, seed: int
) -> Simulations:
    state_path, sims_path = out / STATE_FILE, out / SIMULATIONS_FILE
    if resume:
        if not state_path.exists() or not sims_path.exists():
            raise CalibrationError(f"--resume: {out} holds no interrupted calibration")
        stored = json.loads(state_path.read_text())
        if stored != state:
            diff = [k for k in state if stored.get(k) != state[k]]
            raise CalibrationError(
                f"--resume: {out} holds a calibration of other settings ({', '.join(diff)} "
                "differ); give the same recordings, parameters, trials and seed, or another --out"
            )
        old = Simulations.load(sims_path)
        unit = draws(budget, dims, seed)
        k = min(len(old.done), budget)
        sims = Simulations(
            unit, np.full((budget, n_x), np.nan), np.zeros(budget, bool), np.zeros(budget, bool)
        )
        sims.x[:k], sims.done[:k], sims.failed[:k] = old.x[:k], old.done[:k], old.failed[:k]
        return sims
    if out.exists() and any(out.iterdir()):
        raise CalibrationError(
            f"--out {out} exists and is not empty; choose another directory, or add --resume "
            "to continue the calibration it holds"
        )
    out.mkdir(parents=True, exist_ok=True)
    state_path.write_text(json.dumps(state, indent=1))
    return Simulations(
        draws(budget, dims, seed),
        np.full((budget, n_x), np.nan),
        np.zeros(budget, bool),
        np.zeros(budget, bool),
    )


def calibrate(
    recordings: str | os.PathLike,
    out: str | os.PathLike,
    *,
    parameters: Sequence[Parameter] | None = None,
    budget: int = DEFAULT_BUDGET,
    trials_per_class: int = DEFAULT_TRIALS_PER_CLASS,
    seed: int = 0,
    workers: int = 1,
    executor: cf.Executor | None = None,
    resume: bool = False,
    progress: bool = True,
    report: bool = True,
) -> Calibration:
    """Calibrate the twin to the store ``recordings``, writing ``out/finger.toml``,
    ``out/report.md`` (with its figures) and ``out/calibration.json``."""
    import synth
    from tactile_synth.validation import check_int

    try:
        budget = check_int("--budget", budget, minimum=1)
        trials_per_class = check_int("--trials-per-class", trials_per_class, minimum=2)
        seed = check_int("--seed", seed, minimum=0)
        workers = check_int("--workers", workers, minimum=1)
    except ValueError as exc:
        raise CalibrationError(str(exc)) from None
    parameters = list(parameters or default_parameters())
    out = Path(out)
    data = synth.load_dataset(recordings)
    world = world_of(data)
    x_obs = _summary(data, world)
    store_id = str(data.attrs.get("store_id", ""))
    state = _state(
        {"path": str(Path(recordings).resolve()), "store_id": store_id},
        parameters,
        trials_per_class,
        seed,
    )
    sims = _prepare_out(out, state, budget, len(parameters), len(x_obs), resume=resume, seed=seed)
    run_simulations(
        world,
        parameters,
        sims,
        trials_per_class=trials_per_class,
        seed=seed,
        workers=workers,
        executor=executor,
        save=out / SIMULATIONS_FILE,
        progress=progress,
    )
    posterior = train_posterior(sims.unit, sims.x, seed=seed, usable=x_obs)
    samples = posterior.sample(x_obs, POSTERIOR_SAMPLES, seed)
    result = Calibration(
        out,
        parameters,
        estimates(parameters, samples),
        samples,
        int(sims.done.sum()),
        int(sims.failed.sum()),
        world,
        x_obs,
    )
    from .report import write_outputs

    write_outputs(
        result,
        data,
        recordings=str(recordings),
        trials_per_class=trials_per_class,
        seed=seed,
        figures=report,
    )
    return result


def _summary(data: Any, world: World) -> np.ndarray:
    from .summaries import summarize

    x = summarize(data.signals, data.material, data.label, world.materials)
    if len(x) != len(summary_size(world)):  # pragma: no cover - one definition of both
        raise AssertionError("summary length")
    if not np.isfinite(x).any():
        raise CalibrationError("--recordings: no summary statistic can be read from the store")
    return x
