"""Neighbourhood component feature selection for classification, as MATLAB's ``fscnca``
defines it (Yang, Wang & Zuo 2012, "Neighborhood component feature selection for
high-dimensional data").

One weight ``w_r`` per feature. The weighted distance is the L1 form
``d_w(x_i, x_j) = sum_r w_r^2 |x_ir - x_jr|``; trial ``i`` picks reference ``j != i`` with
probability ``p_ij = exp(-d_w(x_i, x_j) / sigma) / sum_{k != i} exp(-d_w(x_i, x_k) / sigma)``
and ``p_i = sum_j [y_j = y_i] p_ij`` is its leave-one-out probability of being labelled
right. The weights minimise the regularised leave-one-out error

    f(w) = 1 - (1/n) sum_i p_i + lambda * sum_r w_r^2,

starting from ``w = 1`` with L-BFGS (``fscnca``'s defaults: ``sigma = 1``,
``lambda = 1/n``, initial weights one, 15 stored curvature pairs; fscnca switches to
minibatch SGD above 1,000 trials, this module keeps the deterministic full-batch L-BFGS
at every size). ``max_iter`` stops it early if asked. ``lambda`` is best
chosen by cross-validation on the training data (:func:`select_lambda`, MathWorks'
documented procedure: stratified 5-fold, ``lambda`` in ``linspace(0, 20, 20) / n``,
misclassification error of the NCA classifier on the held-out fold).

Speed: the objective and its gradient are computed exactly with two ``O(n^2 d)`` passes,
both in torch's vectorised pairwise-distance kernels (float32): the condensed distances
``torch.pdist(x * w^2, p=1)`` (``w_r^2 |x_ir - x_jr| = |w_r^2 x_ir - w_r^2 x_jr|``), and
its backward pass ``G_ir = sum_j g_ij sign(w_r^2 (x_ir - x_jr))`` for the pair gradients
``g_ij = df/dd_w(i, j)``, from which ``df/dw_r = 2 w_r sum_i G_ir x_ir + 2 lambda w_r``.
The ``n x n`` softmax runs in float64 with the row maximum subtracted (log-sum-exp), so no
kernel underflows however large the distances are with hundreds of features.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Self

import numpy as np
from scipy import optimize
from scipy.spatial.distance import squareform
from threadpoolctl import threadpool_limits

from tactile_synth.validation import check_int

from .base import NotFittedError

#: ``fscnca``'s default kernel width.
DEFAULT_SIGMA: float = 1.0
#: ``fscnca``'s L-BFGS history size (``HessianHistorySize``).
HISTORY: int = 15
#: Folds and grid of :func:`select_lambda` (MathWorks' fscnca tuning example).
CV_FOLDS: int = 5
CV_GRID_TIMES_N: tuple[float, ...] = tuple(np.linspace(0.0, 20.0, 20).tolist())


def _check_xy(features: object, labels: object) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(features, dtype=np.float64)
    y = np.asarray(labels)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"features must be (n, d) with n >= 2; got shape {x.shape}")
    if y.shape != (x.shape[0],):
        raise ValueError(f"labels must have shape ({x.shape[0]},); got {y.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("features contain NaN or inf")
    return x, y


class _Objective:
    """``f(w)`` and ``df/dw`` of fscnca on fixed data: float32 pairwise kernels (torch),
    float64 ``n x n`` softmax (numpy)."""

    def __init__(self, x: np.ndarray, y: np.ndarray, sigma: float, lam: float) -> None:
        import torch

        self.torch = torch
        self.x = torch.as_tensor(np.ascontiguousarray(x, dtype=np.float32))
        self.x64 = self.x.double()
        self.n = x.shape[0]
        same = y[:, None] == y[None, :]
        np.fill_diagonal(same, False)
        self.same = same
        self.sigma = float(sigma)
        self.lam = float(lam)
        self.evaluations = 0

    def __call__(self, w64: np.ndarray) -> tuple[float, np.ndarray]:
        torch = self.torch
        self.evaluations += 1
        w2 = torch.as_tensor(w64 * w64, dtype=torch.float32)
        xw = self.x * w2
        dist = torch.pdist(xw, p=1)  # (n (n-1) / 2,) condensed pair distances, float32
        logits = squareform(dist.numpy().astype(np.float64))
        logits *= -1.0 / self.sigma
        np.fill_diagonal(logits, -np.inf)
        logits -= logits.max(axis=1, keepdims=True)
        p = np.exp(logits, out=logits)
        p /= p.sum(axis=1, keepdims=True)
        p_same = np.where(self.same, p, 0.0)
        p_i = p_same.sum(axis=1)
        # df/dd_ij = -(1/(n sigma)) p_ij (p_i - [y_j = y_i]); a condensed distance stands
        # for both (i, j) and (j, i).
        g = p * p_i[:, None]
        g -= p_same
        g += g.T
        g *= -1.0 / (self.n * self.sigma)
        gpair = torch.as_tensor(squareform(g, checks=False).astype(np.float32))
        g_xw = torch.ops.aten._pdist_backward(gpair, xw, 1.0, dist)  # (n, d)
        g_w2 = (g_xw.double() * self.x64).sum(dim=0).numpy()
        value = 1.0 - float(p_i.mean()) + self.lam * float(np.dot(w64, w64))
        return value, 2.0 * w64 * g_w2 + 2.0 * self.lam * w64


class NCFS:
    """Feature weights by NCA feature selection (``fscnca``); ``ranking_`` orders features
    by weight.

    Parameters: ``lam`` (regulariser; ``None`` = fscnca's default ``1/n``), ``sigma``
    (kernel width, fscnca's default 1), ``max_iter`` (L-BFGS iterations) and ``tol``
    (gradient tolerance). Learned: ``weights_`` (d,), ``ranking_`` (d,) feature indices by
    decreasing weight (ties by index), ``lam_`` (the lambda used), ``n_iter_``,
    ``converged_`` (stopped by a tolerance rather than ``max_iter``), ``objective_``.
    """

    def __init__(
        self,
        *,
        lam: float | None = None,
        sigma: float = DEFAULT_SIGMA,
        max_iter: int = 1000,
        tol: float = 1e-6,
    ) -> None:
        self.lam = lam
        self.sigma = sigma
        self.max_iter = max_iter
        self.tol = tol

    def fit(
        self,
        features: np.ndarray,
        labels: np.ndarray,
        *,
        on_iteration: Callable[[int, np.ndarray], None] | None = None,
    ) -> Self:
        """Learn the weights; ``on_iteration(k, weights)`` (if given) sees the weights
        after each L-BFGS iteration ``k = 1, 2, ...`` (the fit stopped at ``max_iter = k``
        would return exactly these)."""
        x, y = _check_xy(features, labels)
        if not (self.sigma > 0):
            raise ValueError(f"sigma must be > 0; got {self.sigma!r}")
        check_int("max_iter", self.max_iter, minimum=1)
        if not (self.tol > 0):
            raise ValueError(f"tol must be > 0; got {self.tol!r}")
        n, d = x.shape
        lam = 1.0 / n if self.lam is None else float(self.lam)
        if not (lam >= 0):
            raise ValueError(f"lam must be >= 0; got {self.lam!r}")
        objective = _Objective(x, y, self.sigma, lam)
        count = [0]

        def callback(wk: np.ndarray) -> None:
            count[0] += 1
            if on_iteration is not None:
                on_iteration(count[0], np.abs(wk))

        # One BLAS thread for L-BFGS's small linear algebra: its results then do not
        # depend on the BLAS thread count (the pairwise kernels are deterministic).
        with threadpool_limits(limits=1, user_api="blas"):
            res = optimize.minimize(
                objective,
                np.ones(d),
                jac=True,
                method="L-BFGS-B",
                options={"maxiter": self.max_iter, "gtol": self.tol, "maxcor": HISTORY},
                callback=callback,
            )
        w = np.abs(res.x)  # the objective is even in each w_r: report the magnitude
        self.weights_ = w
        self.ranking_ = np.lexsort((np.arange(d), -w))
        self.lam_ = lam
        self.n_iter_ = int(res.nit)
        self.converged_ = int(res.nit) < self.max_iter
        self.objective_ = float(res.fun)
        self._train = (x.astype(np.float32), y)
        return self

    def top(self, k: int) -> np.ndarray:
        """Indices of the ``k`` highest-weighted features."""
        if not hasattr(self, "ranking_"):
            raise NotFittedError("NCFS.top called before fit")
        return self.ranking_[:k]

    def predict(self, features: np.ndarray) -> np.ndarray:
        """fscnca's classifier: each trial takes the class with the largest total
        probability of its reference point among the training trials."""
        import torch

        if not hasattr(self, "weights_"):
            raise NotFittedError("NCFS.predict called before fit")
        x = np.asarray(features, dtype=np.float32)
        xtr, ytr = self._train
        if x.ndim != 2 or x.shape[1] != xtr.shape[1]:
            raise ValueError(f"features must have shape (m, {xtr.shape[1]}); got {x.shape}")
        w2 = torch.as_tensor(self.weights_**2, dtype=torch.float32)
        dist = torch.cdist(torch.as_tensor(x) * w2, torch.as_tensor(xtr) * w2, p=1)
        p = torch.softmax(-dist.double() / self.sigma, dim=1).numpy()
        classes, idx = np.unique(ytr, return_inverse=True)
        prob = np.zeros((x.shape[0], classes.size))
        np.add.at(prob.T, idx, p.T)
        return classes[np.argmax(prob, axis=1)]

    def loss(self, features: np.ndarray, labels: np.ndarray) -> float:
        """Misclassification rate of :meth:`predict` (fscnca's ``classiferror`` loss)."""
        x, y = _check_xy(features, labels)
        return float(np.mean(self.predict(x) != y))


@dataclass(frozen=True)
class LambdaCV:
    """Cross-validation of fscnca's lambda: ``lambdas`` (L,), ``fold_loss`` (L, folds)
    misclassification rates, ``mean_loss`` (L,), and ``best`` (the lambda with the lowest
    mean loss; the smallest such lambda on ties)."""

    lambdas: np.ndarray
    fold_loss: np.ndarray
    mean_loss: np.ndarray
    best: float


def select_lambda(
    features: np.ndarray,
    labels: np.ndarray,
    *,
    lambdas: np.ndarray | None = None,
    folds: int = CV_FOLDS,
    seed: int = 0,
    progress: bool = False,
    **ncfs_params: float | int,
) -> LambdaCV:
    """Choose fscnca's lambda by stratified ``folds``-fold cross-validation on the given
    (training) trials, as MathWorks documents it: for each lambda (default
    ``linspace(0, 20, 20) / n``), fit on ``folds - 1`` folds and score the held-out fold by
    the NCA classifier's misclassification rate; the lowest mean loss wins."""
    from sklearn.model_selection import StratifiedKFold

    x, y = _check_xy(features, labels)
    check_int("folds", folds, minimum=2)
    check_int("seed", seed, minimum=0)
    n = x.shape[0]
    lams = np.asarray(CV_GRID_TIMES_N) / n if lambdas is None else np.asarray(lambdas, float)
    if lams.ndim != 1 or lams.size == 0 or np.any(~np.isfinite(lams)) or np.any(lams < 0):
        raise ValueError("lambdas must be a non-empty 1-D array of finite values >= 0")
    splitter = StratifiedKFold(n_splits=folds, shuffle=True, random_state=seed)
    splits = list(splitter.split(x, y))
    loss = np.empty((lams.size, folds))
    for a, lam in enumerate(lams):
        for k, (tr, va) in enumerate(splits):
            model = NCFS(lam=float(lam), **ncfs_params).fit(x[tr], y[tr])
            loss[a, k] = model.loss(x[va], y[va])
        if progress:
            print(f"  lambda = {lam:.3g} ({lam * n:.2f}/n): CV loss {loss[a].mean():.4f}")
    mean = loss.mean(axis=1)
    return LambdaCV(lambdas=lams, fold_loss=loss, mean_loss=mean, best=float(lams[np.argmin(mean)]))
