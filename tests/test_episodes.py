"""Episode sampler: no repeated classes, shuffled label order, seeded, clear refusals."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.episodes import sample_episodes

LABELS = np.repeat(np.arange(12), 8)


def test_episode_structure_and_disjointness():
    b = sample_episodes(LABELS, n_way=5, k_shot=2, n_query=3, episodes=200, seed=1)
    assert b.support.shape == (200, 5, 2) and b.query.shape == (200, 15)
    for e in range(200):
        assert len(set(b.classes[e])) == 5  # never the same class twice
        s = b.support[e].ravel()
        assert len(set(s)) == s.size and not set(s) & set(b.query[e])
        for n in range(5):
            assert np.all(LABELS[b.support[e, n]] == b.classes[e, n])
        np.testing.assert_array_equal(LABELS[b.query[e]], b.classes[e][b.query_labels[e]])
        assert np.bincount(b.query_labels[e], minlength=5).tolist() == [3] * 5


def test_label_order_and_query_order_are_random():
    b = sample_episodes(LABELS, n_way=5, k_shot=1, n_query=4, episodes=300, seed=2)
    # Episode class 0 is not always the smallest class id ...
    assert np.mean(b.classes[:, 0] == b.classes.min(axis=1)) < 0.5
    # ... and queries are not grouped by class.
    assert np.mean(np.all(np.diff(b.query_labels, axis=1) >= 0, axis=1)) < 0.05


def test_seeded_reproducible_and_seed_sensitive():
    kw = dict(n_way=4, k_shot=1, n_query=2, episodes=50)
    a = sample_episodes(LABELS, seed=7, **kw)
    b = sample_episodes(LABELS, seed=7, **kw)
    c = sample_episodes(LABELS, seed=8, **kw)
    np.testing.assert_array_equal(a.support, b.support)
    np.testing.assert_array_equal(a.query, b.query)
    assert not np.array_equal(a.support, c.support)
    state = np.random.get_state()[1].copy()  # noqa: NPY002 (checking the legacy global RNG)
    sample_episodes(LABELS, seed=7, **kw)
    np.testing.assert_array_equal(np.random.get_state()[1], state)  # noqa: NPY002


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        (dict(n_way=13, k_shot=1, n_query=1), "n_way=13 exceeds the 12 classes"),
        (dict(n_way=5, k_shot=5, n_query=5), "k_shot \\+ n_query = 10"),
        (dict(n_way=1, k_shot=1, n_query=1), "n_way"),
        (dict(n_way=2, k_shot=0, n_query=1), "k_shot"),
    ],
)
def test_impossible_requests_are_refused(kw, match):
    with pytest.raises(ValueError, match=match):
        sample_episodes(LABELS, episodes=3, seed=0, **kw)
