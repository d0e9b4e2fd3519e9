"""The package's argument checks (fingerfriction/_check.py): one vocabulary, one-line messages
that name the argument, the value and what is allowed."""

from __future__ import annotations

import math

import pytest

from fingerfriction._check import in_range


@pytest.mark.parametrize(("args", "kw", "message"), [
    ((-0.1, 0, 5), {"what": "friction coefficient"}, "x must be a friction coefficient in [0, 5], got -0.1"),
    ((True, 0, 5), {}, "x must be in [0, 5], got True"),
    ((0.5, 0, 0.499), {"open_lo": True}, "x must be in (0, 0.499], got 0.5"),
    ((0.0, 0, 0.499), {"open_lo": True}, "x must be in (0, 0.499], got 0.0"),
    ((90, 0, 90), {"open_hi": True, "unit": "degrees"}, "x must be in [0, 90) degrees, got 90"),
    ((0.5, None, 0.3), {"unit": "(relative)"}, "x must be <= 0.3 (relative), got 0.5"),
    ((-1, 0), {"what": "weight"}, "x must be a weight >= 0, got -1"),
    ((math.nan,), {"unit": "px"}, "x must be a finite number in px, got nan"),
    (("abc",), {}, "x must be a finite number, got 'abc'"),
])
def test_a_number_out_of_its_range_is_one_line(args, kw, message):
    with pytest.raises(ValueError) as e:
        in_range("x", *args, **kw)
    assert str(e.value) == message


def test_a_number_in_its_range_comes_back_a_float():
    assert in_range("x", 5, 0, 5) == 5.0 and isinstance(in_range("x", 5, 0, 5), float)
    assert in_range("x", "0.25", 0, 1) == 0.25  # numbers as text, float() decides (the package's policy)
    assert in_range("x", -1e9) == -1e9
