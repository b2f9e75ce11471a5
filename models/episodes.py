"""N-way K-shot episode sampling, seeded and reproducible.

Pitfalls of public samplers avoided: a class never appears twice in an episode (classes
drawn without replacement), the order of an episode's classes is random (so episode
label 0 is not always the smallest class id), queries are shuffled (their order does not
give their classes away), and all randomness comes from a ``numpy.random.Generator``
seeded by the caller, never from global state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_synth.validation import check_int


@dataclass(frozen=True)
class EpisodeBatch:
    """``E`` episodes over a pool of trials (indices into the labels that were sampled).

    support: ``(E, N, K)`` trial indices; ``support[e, n]`` are the K shots of episode
    class ``n``. query: ``(E, N * Q)`` trial indices. query_labels: ``(E, N * Q)`` episode
    class of each query (0..N-1), kept by the evaluator. classes: ``(E, N)`` the pool's
    class id behind each episode class. seed: the sampler's seed.
    """

    support: np.ndarray
    query: np.ndarray
    query_labels: np.ndarray
    classes: np.ndarray
    seed: int

    @property
    def episodes(self) -> int:
        return int(self.support.shape[0])

    @property
    def n_way(self) -> int:
        return int(self.support.shape[1])

    @property
    def k_shot(self) -> int:
        return int(self.support.shape[2])

    @property
    def n_query(self) -> int:
        return int(self.query.shape[1] // self.support.shape[1])


def sample_episodes(
    labels: np.ndarray,
    *,
    n_way: int,
    k_shot: int,
    n_query: int,
    episodes: int,
    seed: int,
) -> EpisodeBatch:
    """Sample ``episodes`` N-way K-shot episodes with ``n_query`` queries per class.

    Only classes with at least ``k_shot + n_query`` trials are eligible; impossible
    requests raise ``ValueError`` naming the argument and what the pool allows.
    """
    y = np.asarray(labels)
    if y.ndim != 1 or y.size == 0:
        raise ValueError(f"labels must be a non-empty 1-D array; got shape {y.shape}")
    check_int("n_way", n_way, minimum=2)
    check_int("k_shot", k_shot, minimum=1)
    check_int("n_query", n_query, minimum=1)
    check_int("episodes", episodes, minimum=1)
    check_int("seed", seed, minimum=0)
    classes, counts = np.unique(y, return_counts=True)
    need = k_shot + n_query
    eligible = classes[counts >= need]
    if classes.size < n_way:
        raise ValueError(
            f"n_way={n_way} exceeds the {classes.size} classes in the pool; "
            f"use n_way <= {classes.size}"
        )
    if eligible.size < n_way:
        raise ValueError(
            f"k_shot + n_query = {need} trials per class are needed, but only "
            f"{eligible.size} classes have that many (the pool has {counts.min()}-"
            f"{counts.max()} per class); lower k_shot/n_query or n_way"
        )
    members = {c: np.flatnonzero(y == c) for c in eligible}
    rng = np.random.default_rng(np.random.SeedSequence([seed, n_way, k_shot, n_query]))
    support = np.empty((episodes, n_way, k_shot), dtype=np.intp)
    query = np.empty((episodes, n_way, n_query), dtype=np.intp)
    chosen = np.empty((episodes, n_way), dtype=classes.dtype)
    for e in range(episodes):
        picked = rng.choice(eligible, size=n_way, replace=False)  # random order
        chosen[e] = picked
        for n, c in enumerate(picked):
            idx = rng.choice(members[c], size=need, replace=False)
            support[e, n] = idx[:k_shot]
            query[e, n] = idx[k_shot:]
    # Shuffle each episode's queries: their order must not reveal their classes.
    flat_q = query.reshape(episodes, -1)
    flat_l = np.broadcast_to(np.arange(n_way)[None, :, None], query.shape).reshape(episodes, -1)
    order = np.argsort(rng.random(flat_q.shape), axis=1)
    return EpisodeBatch(
        support=support,
        query=np.take_along_axis(flat_q, order, axis=1),
        query_labels=np.take_along_axis(flat_l, order, axis=1),
        classes=chosen,
        seed=seed,
    )


def meta_training_episodes(labels: np.ndarray, *, episodes: int, seed: int) -> EpisodeBatch:
    """Episodes for meta-training on the training classes: 5-way 5-shot 5-query, each
    lowered to what the pool holds (way to the class count; shot to half the smallest
    class; queries to the rest of it)."""
    classes, counts = np.unique(labels, return_counts=True)
    shot = max(1, min(5, int(counts.min()) // 2))
    return sample_episodes(
        labels,
        n_way=min(5, classes.size),
        k_shot=shot,
        n_query=max(1, min(5, int(counts.min()) - shot)),
        episodes=episodes,
        seed=seed,
    )


def sample_split_episodes(
    support_labels: np.ndarray,
    query_labels: np.ndarray,
    *,
    n_way: int,
    k_shot: int,
    n_query: int,
    episodes: int,
    seed: int,
) -> EpisodeBatch:
    """``episodes`` N-way K-shot episodes whose support trials come from one pool and whose
    queries come from another, the two pools' labels in one label space (enrolment: the
    support set recorded in one setting, the queries in another).

    Indices address the two pools laid end to end, the support pool first: ``support``
    values lie in ``0..len(support_labels) - 1``, ``query`` values are offset by
    ``len(support_labels)``. Only classes with at least ``k_shot`` support-pool trials and
    ``n_query`` query-pool trials are eligible; impossible requests raise ``ValueError``.
    Drawn as :func:`sample_episodes` draws (classes without replacement in random order,
    queries shuffled), from its own seeded generator.
    """
    ys = np.asarray(support_labels)
    yq = np.asarray(query_labels)
    for arg, y in (("support_labels", ys), ("query_labels", yq)):
        if y.ndim != 1 or y.size == 0:
            raise ValueError(f"{arg} must be a non-empty 1-D array; got shape {y.shape}")
    check_int("n_way", n_way, minimum=2)
    check_int("k_shot", k_shot, minimum=1)
    check_int("n_query", n_query, minimum=1)
    check_int("episodes", episodes, minimum=1)
    check_int("seed", seed, minimum=0)
    s_cls, s_cnt = np.unique(ys, return_counts=True)
    q_cls, q_cnt = np.unique(yq, return_counts=True)
    eligible = np.intersect1d(s_cls[s_cnt >= k_shot], q_cls[q_cnt >= n_query])
    if eligible.size < n_way:
        raise ValueError(
            f"n_way={n_way} needs {n_way} classes with >= {k_shot} support-pool trials and "
            f">= {n_query} query-pool trials; {eligible.size} classes have them"
        )
    s_members = {c: np.flatnonzero(ys == c) for c in eligible}
    q_members = {c: np.flatnonzero(yq == c) + ys.size for c in eligible}
    rng = np.random.default_rng(np.random.SeedSequence([seed, n_way, k_shot, n_query, 0x5E7]))
    support = np.empty((episodes, n_way, k_shot), dtype=np.intp)
    query = np.empty((episodes, n_way, n_query), dtype=np.intp)
    chosen = np.empty((episodes, n_way), dtype=eligible.dtype)
    for e in range(episodes):
        picked = rng.choice(eligible, size=n_way, replace=False)
        chosen[e] = picked
        for n, c in enumerate(picked):
            support[e, n] = rng.choice(s_members[c], size=k_shot, replace=False)
            query[e, n] = rng.choice(q_members[c], size=n_query, replace=False)
    flat_q = query.reshape(episodes, -1)
    flat_l = np.broadcast_to(np.arange(n_way)[None, :, None], query.shape).reshape(episodes, -1)
    order = np.argsort(rng.random(flat_q.shape), axis=1)
    return EpisodeBatch(
        support=support,
        query=np.take_along_axis(flat_q, order, axis=1),
        query_labels=np.take_along_axis(flat_l, order, axis=1),
        classes=chosen,
        seed=seed,
    )
