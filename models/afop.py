"""AFOP-ML (paper Sec. IV): automatic feature optimisation + adapted cosine prototypes.

Offline (``fit``, source classes only): the 386-feature pool, z-scored with training
statistics; NCA feature-selection weights (fscnca, :mod:`models.ncfs`) rank the features;
the D-scan picks the top-D size. Episode time (``predict_episodes``): the top-D z-scored
features of the pool feed the cosine-softmax prototypical head, adapted on each support
set (all episodes batched).

Where each hyper-parameter comes from: ``steps`` = 250, ``lr`` = 1.5e-3 and ``lam`` = 0.10
are the paper's (Sec. IV-D); the D-scan's 5-way-5-shot validation episodes are the paper's
(Sec. IV-C); ``ncfs_sigma`` = 1 is fscnca's default kernel width. ``alpha`` (the head's
temperature, not given in the paper), ``ncfs_lam_n`` (fscnca's lambda times the number of
training trials) and ``ncfs_max_iter`` (L-BFGS iterations) default to the values
``scripts/tune.py`` chose on validation data of the closed-set training half
(:mod:`models.tuned`, evidence in ``docs/tuning.md``). ``ncfs_lam_n="cv"`` instead chooses
lambda inside ``fit`` by fscnca's cross-validation on the training trials (slow).
"""

from __future__ import annotations

import numpy as np

from .base import DScanCurve, FewShotMethod, FitDetails
from .dscan import DEFAULT_CANDIDATES, dscan
from .features import FEATURE_NAMES, pool_of
from .ncfs import DEFAULT_SIGMA, NCFS, select_lambda
from .prototypes import adapt_cosine_head
from .scaling import FeatureScaler
from .tuned import tuned


class AFOPML(FewShotMethod):
    """AFOP-ML: NCA-ranked top-D features and the adapted cosine prototypical head.

    Parameters
    ----------
    seed : int, default 0
        Seeds the D-scan's validation episodes and the head's adaptation.
    steps : int, default 250
        Adam steps of the head's adaptation per episode (paper).
    lr : float, default 1.5e-3
        The head's Adam learning rate (paper).
    lam : float, default 0.10
        Weight of the posteriors' entropy in the head's loss (paper).
    alpha : float or None
        The head's temperature (None: the tuned value, :mod:`models.tuned`).
    candidates : tuple of int
        Candidate sizes D of the D-scan (:data:`models.dscan.DEFAULT_CANDIDATES`).
    dscan_episodes : int, default 200
        5-way 5-shot validation episodes per candidate D.
    ncfs_lam_n : float, "cv" or None
        fscnca's lambda times the number of training trials; ``"cv"`` chooses lambda by
        cross-validation on the training trials (None: the tuned value).
    ncfs_max_iter : int or None
        L-BFGS iterations of the NCA weights (None: the tuned value).
    ncfs_sigma : float, default 1.0
        fscnca's kernel width.

    Attributes
    ----------
    scaler_ : models.scaling.FeatureScaler
        z-scoring of the 386 features with training statistics.
    ncfs_ : models.ncfs.NCFS
        The NCA feature weights and their ranking (``ranking_``).
    ncfs_cv_ : object
        The lambda cross-validation (only with ``ncfs_lam_n="cv"``).
    dscan_ : dict
        The D-scan curve: ``D``, ``mean`` and ``ci95`` arrays.
    D_ : int
        The chosen size D.
    selected_ : numpy.ndarray
        Indices of the top-D features (into :data:`models.features.FEATURE_NAMES`).
    selected_names_ : tuple of str
        Their names.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=3, shapes=("circle", "square", "moon"),
    ...                     n_samples=1000, noise=0.1)
    >>> from models.episodes import sample_episodes
    >>> batch = sample_episodes(data.label, n_way=3, k_shot=1, n_query=2, episodes=4, seed=0)
    >>> model = AFOPML(seed=0, dscan_episodes=20, steps=20).fit(data.signals, data.label)
    >>> model.D_ == len(model.selected_) == len(model.fit_details().selected)
    True
    >>> model.predict_episodes(data.signals, batch.support, batch.query).shape
    (4, 6)
    """

    name = "AFOP-ML"
    cost_hint = (5.0, 2.0)

    def __init__(
        self,
        *,
        seed: int = 0,
        steps: int = 250,
        lr: float = 1.5e-3,
        lam: float = 0.10,
        alpha: float | None = None,
        candidates: tuple[int, ...] = DEFAULT_CANDIDATES,
        dscan_episodes: int = 200,
        ncfs_lam_n: float | str | None = None,
        ncfs_max_iter: int | None = None,
        ncfs_sigma: float = DEFAULT_SIGMA,
    ) -> None:
        super().__init__(seed=seed)
        self.steps = steps
        self.lr = lr
        self.lam = lam
        self.alpha = tuned(self.name, "alpha") if alpha is None else alpha
        self.candidates = candidates
        self.dscan_episodes = dscan_episodes
        self.ncfs_lam_n = tuned(self.name, "ncfs_lam_n") if ncfs_lam_n is None else ncfs_lam_n
        self.ncfs_max_iter = (
            tuned(self.name, "ncfs_max_iter") if ncfs_max_iter is None else ncfs_max_iter
        )
        self.ncfs_sigma = ncfs_sigma
        self._check_settings(
            steps="steps",
            lr="rate",
            lam="weight",
            alpha="rate",
            dscan_episodes="count",
            ncfs_max_iter="count",
            ncfs_sigma="rate",
        )

    def _fit(self, signals: np.ndarray, labels: np.ndarray, features: np.ndarray | None) -> None:
        raw = pool_of(signals, features)
        self.scaler_ = FeatureScaler().fit(raw)
        z = self.scaler_.transform(raw)
        n = z.shape[0]
        if self.ncfs_lam_n == "cv":
            self.ncfs_cv_ = select_lambda(
                z, labels, seed=self.seed, sigma=self.ncfs_sigma, max_iter=self.ncfs_max_iter
            )
            lam = self.ncfs_cv_.best
        elif isinstance(self.ncfs_lam_n, int | float) and self.ncfs_lam_n >= 0:
            lam = float(self.ncfs_lam_n) / n
        else:
            raise ValueError(f"ncfs_lam_n must be a number >= 0 or 'cv'; got {self.ncfs_lam_n!r}")
        self.ncfs_ = NCFS(lam=lam, sigma=self.ncfs_sigma, max_iter=self.ncfs_max_iter).fit(
            z, labels
        )
        scan = dscan(
            z,
            labels,
            self.ncfs_.ranking_,
            candidates=self.candidates,
            episodes=self.dscan_episodes,
            seed=self.seed,
        )
        self.dscan_ = scan.as_dict()
        self.D_ = scan.best
        self.selected_ = self.ncfs_.ranking_[: self.D_].copy()

    def fit_details(self) -> FitDetails:
        """The top-D features (``selected_``) and the D-scan they were chosen by
        (``dscan_``), for the benchmark's ``selection`` and ``dscan`` records."""
        details = super().fit_details()
        if getattr(self, "selected_", None) is None:
            return details
        scan = self.dscan_
        return FitDetails(
            selected=tuple(np.asarray(self.selected_).tolist()),
            dscan=DScanCurve(
                tuple(np.asarray(scan["D"]).tolist()),
                tuple(np.asarray(scan["mean"]).tolist()),
                tuple(np.asarray(scan["ci95"]).tolist()),
            ),
            meta_curve=details.meta_curve,
            meta_gradient=details.meta_gradient,
        )

    @property
    def selected_names_(self) -> tuple[str, ...]:
        return tuple(FEATURE_NAMES[i] for i in self.selected_)

    def embed(self, signals: np.ndarray, features: np.ndarray | None = None) -> np.ndarray:
        """Top-D z-scored features ``(n, D)`` of trials (after ``fit``)."""
        raw = pool_of(signals, features)
        return self.scaler_.transform(raw)[:, self.selected_]

    def _predict(
        self,
        signals: np.ndarray,
        support: np.ndarray,
        query: np.ndarray,
        features: np.ndarray | None,
    ) -> np.ndarray:
        return adapt_cosine_head(
            self.embed(signals, features),
            support,
            query,
            steps=self.steps,
            lr=self.lr,
            lam=self.lam,
            alpha=self.alpha,
        )
