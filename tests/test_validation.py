import math

import pytest

from shapes.validation import check_choice, check_int, check_positive


def test_check_choice_accepts_and_hints() -> None:
    assert check_choice("shape", "moon", ["moon", "square"]) == "moon"
    with pytest.raises(ValueError, match=r"shape must be one of moon, square; got 'mon'.*'moon'"):
        check_choice("shape", "mon", ["moon", "square"])


@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "1", True, None])
def test_check_positive_rejects(bad: object) -> None:
    with pytest.raises(ValueError, match="force_n"):
        check_positive("force_n", bad, unit="N")


def test_check_int() -> None:
    assert check_int("seed", 3, minimum=0) == 3
    with pytest.raises(ValueError, match="seed must be >= 0"):
        check_int("seed", -1, minimum=0)
    with pytest.raises(ValueError, match="seed must be an integer"):
        check_int("seed", 1.5)
