"""Evidence texts the effects share: what the residual shows at the lines of an accepted effect."""
from __future__ import annotations

import numpy as np

from gearrom.calibrate.registry import EffectPlugin
from gearrom.calibrate.residual import fit_lines

UM = 1e-6


def line_amp(x: np.ndarray, run, shaft: str, order: int = 1) -> float:
    """Amplitude of the line at ``order`` of ``shaft`` in the signal ``x`` of ``run`` (its units)."""
    line = [[order, 0.0]] if shaft == "input" else [[0.0, order]]
    return float(abs(fit_lines(x, run.theta_in_rad, run.theta_out_rad, np.array(line))[0]))


def same_line(mesh, shaft: str) -> str:
    """`` (= order k of the <other> shaft, the same line)`` when order 1 of ``shaft`` is an integer order of
    the other shaft (integer ratio), else ``""``: the line carries both names."""
    a, b = (mesh.z1, mesh.z2) if shaft == "input" else (mesh.z2, mesh.z1)
    if b % a:
        return ""
    return f" (= order {b // a} of the {'output' if shaft == 'input' else 'input'} shaft, the same line)"


def once_per_rev_evidence(ctx, t, D: list, moves_shafts: bool) -> str:
    """The once-per-rev line in the TE, how much the other channel moves at it (measured and predicted),
    and the split test's verdict when it decided between runout and an encoder error."""
    shaft = "input" if t.cand.target.startswith("input") else "output"
    other = 2 if shaft == "input" else 1
    m, d, c = ctx.models[0], D[0], t.contrib[0]
    te = line_amp(d[0], m.run, shaft) / UM
    oth_meas = line_amp(d[other], m.run, shaft) / UM
    oth_pred = line_amp(c[other], m.run, shaft) / UM
    txt = (f"; order 1 of the {shaft} shaft{same_line(m.run.mesh, shaft)}: {te:.3g} um in the TE; the other channel "
           f"({'output' if other == 2 else 'input'}) moves {oth_meas:.3g} um at that order (this effect "
           f"predicts {oth_pred:.3g} um; "
           + ("real shaft motion: a mesh excitation, not a measurement error)" if moves_shafts
              else "an encoder error moves no shaft)"))
    st = t.info.get("split_test")
    if st:
        verdict = {'real': 'the shaft moves', 'none': 'nothing moves', 'unclear': 'unclear'}[st['verdict']]
        txt += f"; split test: other channel {100 * st['other_channel_share']:.1f} % of the TE line -> {verdict}"
    return txt


class ShaftOrderPlugin(EffectPlugin):
    """The hooks of an effect fitted as a shaft-order line (:class:`~gearrom.calibrate.fit.ShaftOrder`): the
    once-per-rev evidence (for order 1) and the residual line at its order of its shaft."""

    def evidence(self, ctx, trial, D):
        if trial.cand.order != 1:
            return (f"; order {trial.cand.order} of the {trial.cand.target.split('_')[0]} shaft"
                    + (", in one channel only: no shaft moves" if trial.cand.measurement_only else ""))
        return once_per_rev_evidence(ctx, trial, D, moves_shafts=not trial.cand.measurement_only)

    def explains_line(self, target, label):
        return label == f"{target.split('_')[0]} order {self.candidate.order}"
