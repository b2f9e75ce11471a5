import math

import pytest

from tactile_synth.validation import check_choice, check_int, check_non_negative, check_positive


def test_check_choice_accepts_and_hints() -> None:
    assert check_choice("shape", "moon", ["moon", "square"]) == "moon"
    with pytest.raises(ValueError, match=r"shape must be one of moon, square; got 'mon'.*'moon'"):
        check_choice("shape", "mon", ["moon", "square"])


@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "1", True, None])
def test_check_positive_rejects(bad: object) -> None:
    with pytest.raises(ValueError, match="force_n"):
        check_positive("force_n", bad, unit="N")


@pytest.mark.parametrize("bad", [-1e-9, math.nan, math.inf, "0", True, None])
def test_check_non_negative_rejects(bad: object) -> None:
    with pytest.raises(ValueError, match="lam must be"):
        check_non_negative("lam", bad)


def test_check_non_negative_accepts_zero() -> None:
    assert check_non_negative("lam", 0) == 0.0 and check_non_negative("lam", 2.5) == 2.5


def test_check_int() -> None:
    assert check_int("seed", 3, minimum=0) == 3
    with pytest.raises(ValueError, match="seed must be >= 0"):
        check_int("seed", -1, minimum=0)
    with pytest.raises(ValueError, match="seed must be an integer"):
        check_int("seed", 1.5)


UNDERSCORED = "(underscores are not accepted: write"


@pytest.mark.parametrize(
    ("argv", "option", "words"),
    [
        (["generate", "--out", "d", "--trials-per-class", "1_000"], "--trials-per-class",
         f"'1_000' is not a whole number {UNDERSCORED} '1000'"),
        (["generate", "--out", "d", "--force", "1", "0_5"], "--force",
         f"'0_5' is not a number {UNDERSCORED} '05'"),
        (["plot-trial", "--shape", "moon", "--material", "resin", "--out", "t.png", "--speed",
          "1_0"], "--speed", f"'1_0' is not a number {UNDERSCORED} '10'"),
        (["benchmark", "all", "--data", "d", "--out", "o", "--episodes", "1_00"], "--episodes",
         f"'1_00' is not a whole number {UNDERSCORED} '100'"),
        (["run", "--out", "o", "--seed", "1_0"], "--seed",
         f"'1_0' is not a whole number {UNDERSCORED} '10'"),
        (["run", "--out", "o", "--threads", "ten"], "--threads", "invalid int value: 'ten'"),
    ],
    ids=["generate --trials-per-class", "generate --force", "plot-trial --speed",
         "benchmark --episodes", "run --seed", "run --threads (wording kept)"],
)  # fmt: skip
def test_numeric_options_of_every_command_refuse_underscores(capsys, argv, option, words):
    """As import's options do: ``int()``/``float()`` would read ``1_000`` as 1000. Parsed
    only, so that an option taken as a number runs nothing."""
    from benchmark.cli import build_parser

    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    errors = [x for x in err.splitlines() if ": error: " in x]
    assert errors == [err.strip().splitlines()[-1]], err
    assert errors[0].startswith(f"tactile-synth {argv[0]}: error: argument {option}: {words}")
