"""Episode sampling for the benchmark.

The sampler lives in :mod:`models.episodes` because methods need it too (D-scan validation
episodes, MAML's meta-training episodes) and ``models`` may not import ``benchmark``;
this module is the benchmark's name for it.
"""

from __future__ import annotations

from models.episodes import EpisodeBatch, sample_episodes, sample_split_episodes

__all__ = ["EpisodeBatch", "sample_episodes", "sample_split_episodes"]
