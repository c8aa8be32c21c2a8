"""How the diagnosis words a detection limit: a number where the recording could show the
effect, "not detectable on this recording" where its limit is infinite, not a number or absurd
(it was printed as `6.15e+300 kg` and `inf`)."""
import math

import pytest

from cosim.discrepancy.diagnosis import UNDETECTABLE_RATIO, detection_limit_text


@pytest.mark.parametrize("size", [math.inf, math.nan, 6.15e300, 0.05 * UNDETECTABLE_RATIO * 1.01])
def test_an_effect_the_recording_does_not_excite_is_said_so_without_a_number(size):
    s = detection_limit_text(size, 0.05, "kg")
    assert s.startswith("not detectable on this recording") and "e+" not in s and "inf" not in s and "nan" not in s
    assert "a small one is 0.05 kg" in s


def test_a_finite_limit_is_given_with_its_unit():
    assert detection_limit_text(0.2, 0.05, "kg") == "this recording cannot reveal it below 0.2 kg (a small one is " \
                                                    "0.05 kg)"
