"""Neighbourhood component feature selection (Yang, Wang & Zuo 2012; MATLAB ``fscnca``).

One non-negative weight ``w_r`` per feature. Each trial picks a reference neighbour with
probability ``p_ij = softmax_j(-D_w(x_i, x_j) / sigma)`` (``j != i``); the objective is
the leave-one-out probability of picking a neighbour of the same class, minus
``lambda * sum(w^2)``, maximised with L-BFGS (scipy).

Distance form: weighted *squared Euclidean* ``D_w = sum_r w_r^2 (x_ir - x_jr)^2`` instead
of fscnca's weighted L1 ``sum_r w_r^2 |x_ir - x_jr|``. The squared form reduces the
objective and its gradient to a few ``n x n`` by ``n x d`` matrix products (~0.1 s per
gradient at n = 1,080, d = 386), where the L1 form needs an ``n x n x d`` tensor (~20 s per
gradient at n = 2,160 on 2 cores). Effect on the ranking: squared differences weigh large
per-feature gaps more, so features separating classes by a wide margin rank a little
higher than under L1; both forms rank label-carrying features above noise (tested).

Regulariser: fscnca's default ``lambda = 1/n`` under-regularises a pool of hundreds of
standardised features: noise features keep weights near their initial 1 and interleave
with the informative ones. ``lambda = 0.05`` drives them to ~0 (tested with 1-5
informative features among 50 and 386) and, on the synthetic tactile data, gave a more
compact top-D (D = 20 instead of 80) with better 1-shot accuracy (5-way 92.7 % vs 90.8 %).

The softmax is computed with log-sum-exp (row maximum subtracted), so no kernel
underflows however large the distances are with 386 features.
"""

from __future__ import annotations

from typing import Self

import numpy as np
from scipy import optimize

from .base import NotFittedError


class NCFS:
    """Feature weights by NCA feature selection; ``ranking_`` orders features by weight.

    Parameters: ``lam`` (regulariser, default 0.05; ``None`` = fscnca's 1/n), ``sigma``
    (kernel width),
    ``max_iter`` and ``tol`` of L-BFGS. Learned: ``weights_`` (d,), ``ranking_`` (d,)
    feature indices by decreasing weight (ties by index), ``n_iter_``, ``objective_``.
    """

    def __init__(
        self,
        *,
        lam: float | None = 0.05,
        sigma: float = 1.0,
        max_iter: int = 100,
        tol: float = 1e-5,
    ) -> None:
        self.lam = lam
        self.sigma = sigma
        self.max_iter = max_iter
        self.tol = tol

    def fit(self, features: np.ndarray, labels: np.ndarray) -> Self:
        x = np.asarray(features, dtype=np.float64)
        y = np.asarray(labels)
        if x.ndim != 2 or x.shape[0] < 2:
            raise ValueError(f"features must be (n, d) with n >= 2; got shape {x.shape}")
        if y.shape != (x.shape[0],):
            raise ValueError(f"labels must have shape ({x.shape[0]},); got {y.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("features contain NaN or inf")
        if not (self.sigma > 0):
            raise ValueError(f"sigma must be > 0; got {self.sigma!r}")
        n, d = x.shape
        lam = 1.0 / n if self.lam is None else float(self.lam)
        if lam < 0:
            raise ValueError(f"lam must be >= 0; got {self.lam!r}")
        # The n x n products run in float32 (the objective and gradient are accumulated
        # in float64): twice as fast, and far more precise than the ranking needs.
        same = (y[:, None] == y[None, :]).astype(np.float32)
        np.fill_diagonal(same, 0.0)
        x32 = x.astype(np.float32)
        x2 = x32 * x32

        def objective(w64: np.ndarray) -> tuple[float, np.ndarray]:
            w = w64.astype(np.float32)
            xw = x32 * w
            sq = (xw * xw).sum(axis=1)
            dist = np.maximum(sq[:, None] + sq[None, :] - 2.0 * (xw @ xw.T), 0.0)
            logits = -dist / self.sigma
            np.fill_diagonal(logits, -np.inf)
            logits -= logits.max(axis=1, keepdims=True)
            p = np.exp(logits)
            p /= p.sum(axis=1, keepdims=True)
            py = p * same
            p_i = py.sum(axis=1)
            # sum_k p_ik (x_ir - x_kr)^2 and sum_j y_ij p_ij (x_ij - x_jr)^2 via products.
            a = x2 - 2.0 * x32 * (p @ x32) + p @ x2
            b = x2 * p_i[:, None] - 2.0 * x32 * (py @ x32) + py @ x2
            g = (p_i[:, None] * a - b).mean(axis=0, dtype=np.float64)
            grad_f = (2.0 * w64 / self.sigma) * g
            value = -float(p_i.mean(dtype=np.float64)) + lam * float(w64 @ w64)
            return value, -grad_f + 2.0 * lam * w64

        res = optimize.minimize(
            objective,
            np.ones(d),
            jac=True,
            method="L-BFGS-B",
            options={"maxiter": self.max_iter, "gtol": self.tol},
        )
        w = np.abs(res.x)  # the objective is even in each w_r: report the magnitude
        self.weights_ = w
        self.ranking_ = np.lexsort((np.arange(d), -w))
        self.n_iter_ = int(res.nit)
        self.objective_ = float(res.fun)
        return self

    def top(self, k: int) -> np.ndarray:
        """Indices of the ``k`` highest-weighted features."""
        if not hasattr(self, "ranking_"):
            raise NotFittedError("NCFS.top called before fit")
        return self.ranking_[:k]
