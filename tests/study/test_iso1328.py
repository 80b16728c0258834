"""ISO 1328-1:2013 tolerance formulas.

References: hand evaluation of the clause 5.3 formulas (written out below, independent of the code's
vectorisation), and the seed gear drawing of thesis-helical (annex 11.1, part 02T 311 131 AS), which
specifies the runout tolerance F_r = 22 um for z = 32, m_n = 1.5 mm, beta = 32 deg, b = 18 mm: the
2013 formula 0.9 F_pT gives 22 um at class 6.
"""
import math

import pytest

from gearrom.config import load_config
from gearrom.errors import ConfigError
from gearrom.study.iso1328 import iso1328_tolerances, pair_tolerances, round_iso


def test_rounding_rule():
    assert round_iso(10.6) == 11.0 and round_iso(7.26) == 7.5 and round_iso(7.2) == 7.0 and round_iso(4.44) == 4.4


def test_class5_by_hand():
    # d = 100 mm, m_n = 2 mm, b = 20 mm, class 5 (step factor 1):
    # f_pT = 0.1 + 0.8 + 5 = 5.9 -> 6.0; F_pT = 0.2 + 5.5 + 1.4 + 12 = 19.1 -> 19;
    # f_HbT = 0.5 + 0.35 sqrt(20) + 4 = 6.065 -> 6.0; F_rT = 0.9 * 19.1 = 17.19 -> 17
    t = iso1328_tolerances(5, 100.0, 2.0, 20.0)
    assert (t.f_pT, t.F_pT, t.f_HbT, t.F_rT) == pytest.approx((6.0e-6, 19e-6, 6.0e-6, 17e-6))


def test_class_step_sqrt2():
    # class 7 = class 5 x 2 before rounding: F_pT = 38.2 -> 38
    assert iso1328_tolerances(7, 100.0, 2.0, 20.0).F_pT == pytest.approx(38e-6)


def test_drawing_runout_thesis_helical():
    pair = load_config("thesis-helical").pair
    t1, _ = pair_tolerances(pair, 6)
    assert t1.F_rT == pytest.approx(22e-6)
    assert pair_tolerances(pair, 5)[0].F_rT != pytest.approx(22e-6)


@pytest.mark.parametrize("args", [(0, 100, 2, 20), (12, 100, 2, 20), (5, 1.0, 2, 20), (5, 100, 0.1, 20),
                                  (5, 100, 2, math.nan)])
def test_out_of_range(args):
    with pytest.raises(ConfigError):
        iso1328_tolerances(*args)
