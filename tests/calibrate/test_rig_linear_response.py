"""The linearized drivetrain's response change that the diagnosis uses to re-tune a low rig mode.

Reference: the ROM's own time-domain response to a small multisine kinematic error
(:func:`gearrom.calibrate.model.build_run_model`, two simulations per shaft on the exudyn model with the
mesh law, the parametric excitation and the speed-controlled motor) on the nominal and on the re-tuned
rig. :meth:`~gearrom.calibrate.simulator.RomSimulator.response_ratio` comes from the linearized state
space at the mean mesh stiffness instead; the simulated nominal response times that ratio must give
the simulated re-tuned response at the low input orders, where the moved mode acts.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

datasim = pytest.importorskip("datasim")

from gearrom.calibrate.effects.torsional_mode import _Retuned  # noqa: E402
from gearrom.calibrate.model import build_run_model  # noqa: E402
from gearrom.calibrate.residual import load_run  # noqa: E402
from gearrom.calibrate.simulator import default_simulator  # noqa: E402
from gearrom.config import as_config  # noqa: E402
from gearrom.signal import GearMeshInfo  # noqa: E402
from gearrom.signal.config import settings_from_config  # noqa: E402


def test_linear_ratio_carries_the_simulated_response_to_a_retuned_drive(tmp_path):
    """J_motor x0.5 moves the drive's mode from about 165 to 206 Hz; at 2000 rpm input orders 2-10
    (67-333 Hz) straddle it. The predicted response matches the re-simulated one within 2 % of its
    largest magnitude over those orders, where the nominal differs from it by more than 20 %."""
    cfg = as_config("thesis-rig")
    (path,) = datasim.make_case_files(tmp_path, datasim.Case("clean", ()), rpms=(2000.0,))
    te_s, read_s = settings_from_config(cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = load_run(path, GearMeshInfo.from_config(cfg), None, read_s, te_s)
        sim = default_simulator(cfg)
        scale = (("J_motor", 0.5),)
        nominal = build_run_model(sim, run)
        retuned = build_run_model(_Retuned(sim, scale), run)
    orders, h0 = nominal.H["input"]
    _, h1 = retuned.H["input"]
    ratio = sim.response_ratio(run.rpm_in, run.torque_out_Nm, scale, orders * run.rpm_in / 60.0)
    band = (orders >= 2) & (orders <= 10)
    te0, te1, pred = h0[0, band], h1[0, band], (h0 * ratio)[0, band]
    ref = np.abs(te1).max()
    assert np.abs(te0 - te1).max() > 0.2 * ref  # the mode's move is visible in the simulated response
    np.testing.assert_array_less(np.abs(pred - te1), 0.02 * ref)
