"""Known answer: classes that differ only by the frequency of a tone in the PVDF channels
are recognised about as well when the tones lie at 80-200 Hz (texture vibration of fine
machining marks) as at 5-20 Hz, by every method that reads the raw signals.

One training set holds 8 tone classes of each band; 5-way-5-shot test episodes are drawn
from 5 held-out tone classes of one band at a time (frequencies interleaved with the
training ones). A method that averages away the upper band is at chance there.
"""

from __future__ import annotations

import numpy as np
import pytest

from models.episodes import sample_episodes
from models.registry import make_method

RATE_HZ = 1000
N_SAMPLES = 2000
TRIALS = 10
BANDS_HZ = {"low": (5.0, 20.0), "high": (80.0, 200.0)}
#: Settings that keep the test fast; the input path (resampling, wavelet scales, frame
#: spectra) is the benchmark's.
SETTINGS = {
    "MAML": dict(max_iterations=100, val_episodes=10, inner_lr=0.1, test_steps=10),
    "CNN": dict(steps=30, lr=1e-2),
    "BiLSTM": dict(steps=30, lr=1e-2),
    "CWT-ResNet-ML": dict(max_epochs=6, val_episodes=20),
}
EPISODES = 20


def tone_set(freqs_hz: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``TRIALS`` trials per frequency: a tone of random amplitude and phase on both PVDF
    channels, slow random drift on the strain-gauge channels, white noise on all."""
    t = np.arange(N_SAMPLES) / RATE_HZ
    signals, labels = [], []
    for label, f in enumerate(freqs_hz):
        for _ in range(TRIALS):
            amp = rng.uniform(0.5, 1.5, size=(2, 1))
            phase = rng.uniform(0, 2 * np.pi, size=(2, 1))
            pvdf = amp * np.sin(2 * np.pi * f * t + phase)
            drift = np.cumsum(rng.standard_normal((2, N_SAMPLES)), axis=1) * 0.02
            x = np.concatenate([pvdf, 1.0 + drift]) + 0.5 * rng.standard_normal((4, N_SAMPLES))
            signals.append(x.astype(np.float32))
            labels.append(label)
    return np.stack(signals), np.asarray(labels)


def band_accuracy(name: str, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    freqs = {b: np.geomspace(lo, hi, 13) for b, (lo, hi) in BANDS_HZ.items()}
    test = np.arange(13) % 3 == 0  # 5 test tones per band, 8 training tones between them
    train_f = np.concatenate([f[~test] for f in freqs.values()])
    x_train, y_train = tone_set(train_f, rng)
    model = make_method(name, seed=seed, **SETTINGS[name]).fit(x_train, y_train)
    out = {}
    for b, f in freqs.items():
        x, y = tone_set(f[test], rng)
        batch = sample_episodes(y, n_way=5, k_shot=5, n_query=5, episodes=EPISODES, seed=seed)
        pred = model.predict_episodes(x, batch.support, batch.query)
        out[b] = float((pred == batch.query_labels).mean())
    return out


#: Largest allowed shortfall of the high band against the low band. MAML's short
#: meta-training here leaves it favouring one band or the other depending on the seed
#: (high minus low from -0.33 to +0.38 over seeds 0-8 at 100 outer steps and three of
#: them at 300), so its
#: bound only checks that the high band is not lost, as it is when the input is
#: block-averaged to 125 Hz (high-band accuracy at chance).
MAX_GAP = {"MAML": 0.4, "CNN": 0.12, "BiLSTM": 0.12, "CWT-ResNet-ML": 0.12}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SETTINGS))
def test_high_band_tones_recognised_as_well_as_low_band(name):
    """Chance is 0.2 (500 queries per band: standard error about 0.02). Over seeds 0-9 the
    high band scored at least 0.76 (CNN), 0.99 (BiLSTM) and 0.32 (MAML, seeds 0-8), and
    fell short of the low band by at most 0.00, 0.00 and 0.33; CWT-ResNet-ML, trained
    again on all training tones for its chosen epoch count, at least 0.96 over seeds 0-4,
    at most 0.02 short of the low band."""
    acc = band_accuracy(name, seed=0)
    assert acc["high"] > 0.3, acc
    assert acc["high"] > acc["low"] - MAX_GAP[name], acc
