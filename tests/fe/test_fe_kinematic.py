"""Unloaded (kinematic) TE from manufacturing errors, against closed-form geometry.

References: an eccentricity e of the input gear moves its flanks along the line of action by
e cos(angle), so the TE is a once-per-revolution sinusoid with peak-to-peak 2 e = F_r (Smith,
Gear Noise and Vibration, 2003, ch. 2); a single-tooth pitch error f (material added on one
tooth) advances the output by f while that tooth is the first to touch, i.e. TE = -f there.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.fe.ltca import SpurLTCA
from gearrom.fe.sweep import kinematic_te


@pytest.fixture(scope="module")
def spur_ltca(tmp_path_factory):
    from gearrom.fe.mesh2d import MeshSettings
    from gearrom.fe.sweep import build_ltca

    pair = load_config("thesis-spur").pair
    return build_ltca(pair, MeshSettings(flank_size=0.06e-3, tooth_size=0.6e-3, body_size=4e-3),
                      cache_dir=tmp_path_factory.mktemp("k"))


def _with_micro(pair, i, **kw):
    gears = list(pair.gears)
    gears[i] = dataclasses.replace(gears[i], micro=dataclasses.replace(gears[i].micro, enabled=True, **kw))
    return dataclasses.replace(pair, gears=tuple(gears))


@pytest.mark.parametrize("gear", [0, 1])
def test_runout_gives_once_per_rev_te(spur_ltca, gear):
    pair = _with_micro(spur_ltca.pair, gear, runout=20e-6)
    z = pair.z[gear]
    # one revolution of the gear with the runout
    angle, te = kinematic_te(SpurLTCA(pair, spur_ltca.c), n_cycles=z, n_per_cycle=8)
    assert np.ptp(te) == pytest.approx(20e-6, rel=0.02)
    # once per revolution of that gear: the first harmonic carries the signal
    spec = np.abs(np.fft.rfft(te - te.mean()))
    assert np.argmax(spec) == 1


def test_single_pitch_error_shows_while_that_tooth_leads(spur_ltca):
    z = spur_ltca.pair.z[0]
    fp = np.zeros(z)
    fp[5], fp[6] = 10e-6, -10e-6  # tooth 5 sits 10 um ahead, tooth 6 back in place
    pair = _with_micro(spur_ltca.pair, 0, pitch_deviations=tuple(fp))
    angle, te = kinematic_te(SpurLTCA(pair, spur_ltca.c), n_per_cycle=8)
    offset = np.median(te)  # the cumulative deviation is mean-free; most positions see the same offset
    assert te.min() == pytest.approx(offset - 10e-6, abs=1e-9)
    assert np.ptp(te) == pytest.approx(10e-6, abs=1e-9)
