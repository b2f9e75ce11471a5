"""Sensor faults (synth.faults) and the stress suite's sensor families: each fault does
what it says, measurably, deterministically per trial, and severity 0 is the identity."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.stress import families
from synth import faults
from synth.faults import requantise

T = 2000


def _windows(n: int = 6, seed: int = 0) -> np.ndarray:
    """Recorded-looking windows: a tone per channel, on the DAQ's code grid."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) / 1000.0
    x = np.stack(
        [[0.5 * np.sin(2 * np.pi * (5 + 3 * c) * t + rng.uniform(0, 6)) for c in range(4)]
         for _ in range(n)]
    )  # fmt: skip
    return requantise(x)


SEEDS = np.arange(100, 106)


def test_requantise_keeps_recorded_windows_bit_for_bit():
    x = _windows()
    np.testing.assert_array_equal(requantise(x), x)


def test_added_noise_has_the_requested_rms_on_the_named_channels_only():
    x = np.zeros((6, 4, T), np.float32)
    y = faults.added_noise(x, (0, 1), 0.01, SEEDS, key=1)
    rms = y.std(axis=2)
    np.testing.assert_allclose(rms[:, :2], 0.01, rtol=0.05)
    assert np.all(y[:, 2:] == 0)
    assert x.max() == 0  # the input is not changed


def test_every_fault_depends_on_its_trial_alone_not_on_the_batch():
    x = _windows()
    calls = [
        lambda a, s: faults.added_noise(a, (0, 2), 0.02, s, key=3),
        lambda a, s: faults.offset(a, (2, 3), 0.1, s, key=3),
        lambda a, s: faults.dead_channel(a, 0.5, s, key=3),
        lambda a, s: faults.dropped_samples(a, 0.05, s, key=3),
    ]
    for f in calls:
        whole = f(x, SEEDS)
        for i in (0, 4):
            np.testing.assert_array_equal(f(x[i : i + 1], SEEDS[i : i + 1])[0], whole[i])
        np.testing.assert_array_equal(f(x, SEEDS), whole)  # and repeatable


def test_offset_moves_each_gauge_by_the_value_with_a_per_trial_sign():
    x = _windows()
    y = faults.offset(x, (2, 3), 0.3, SEEDS, key=7)
    shift = (y - x).mean(axis=2)
    np.testing.assert_allclose(np.abs(shift[:, 2:]), 0.3, atol=2e-4)
    assert np.all(shift[:, :2] == 0)
    assert len({tuple(np.sign(s[2:])) for s in shift}) > 1  # signs differ between trials


def test_gain_error_scales_every_trial_alike():
    x = _windows()
    y = faults.gain_error(x, (0, 1, 2, 3), 0.2, key=5)
    ratio = np.abs(y).max(axis=2) / np.abs(x).max(axis=2)
    assert np.allclose(ratio, ratio[0], atol=2e-3)  # one instrument: the same for every trial
    assert np.all(np.isclose(ratio[0], 0.8, atol=2e-3) | np.isclose(ratio[0], 1.2, atol=2e-3))


def test_dead_channel_silences_one_channel_for_the_share_of_the_window():
    x = _windows()
    y = faults.dead_channel(x, 0.5, SEEDS, key=2)
    for i in range(x.shape[0]):
        changed = np.flatnonzero((y[i] != x[i]).any(axis=1))
        assert changed.size == 1
        quiet = np.abs(y[i, changed[0]]) < 2e-3
        assert abs(quiet.mean() - 0.5) < 0.06  # the tone's own zero crossings add a little
    whole = faults.dead_channel(x, 1.0, SEEDS, key=2)
    assert all((np.abs(w) < 2e-3).all(axis=1).sum() == 1 for w in whole)


def test_clipping_bounds_every_channel():
    x = _windows()
    y = faults.clipped(x, 0.2)
    assert np.abs(y).max() <= 0.2 and np.abs(x).max() > 0.4
    np.testing.assert_array_equal(y[np.abs(x) < 0.2], x[np.abs(x) < 0.2])


def test_dropped_samples_move_the_rest_up_and_hold_the_end():
    x = np.tile(np.arange(T, dtype=np.float32), (2, 4, 1))
    y = faults.dropped_samples(x, 0.1, SEEDS[:2], key=4)
    kept = round(0.1 * (T // 16)) * 16
    for row in y[:, 0]:
        assert np.all(np.diff(row[: T - kept]) > 0)  # still in order, some values skipped
        assert np.all(row[T - kept :] == row[T - kept - 1])
        assert np.diff(row[: T - kept]).max() > 1


@pytest.mark.parametrize(
    "name",
    [
        n
        for n in families.FAMILY_NAMES
        if "noise" in n or n in ("sg-offset", "gain", "dead-channel", "clipping", "dropped-samples")
    ],
)
def test_sensor_families_are_the_identity_at_severity_0_and_change_signals_at_5(name):
    fam = families.get(name)
    assert fam.kind == "sensor"
    x = _windows()
    np.testing.assert_array_equal(fam.apply(x, fam.value(0), SEEDS), x)
    y = fam.apply(x, fam.value(5), SEEDS)
    assert y.shape == x.shape and y.dtype == np.float32
    assert np.abs(y - x).max() > 1e-3
