"""Static consistency of the explicit FE model with the quasi-static LTCA: the gate before any dynamic comparison.

Both models describe the same gears under the same torque, so before their dynamics are compared
their static TE must agree. Static solves of the explicit model (dynamic relaxation of the same mesh,
:mod:`gearrom.validation.explicit_static`) at ``n`` input angles spread over one mesh period and at
two torques are set against the LTCA's loaded static TE at the same angles (table phase of the FE
start plus the input angle):

* mean TE over the period within 2 %;
* RMS of the difference of the two curves within 3 % of the LTCA mean;
* GMF1, GMF2, GMF3 amplitudes of the two curves within 5, 10, 10 % (from the ``n`` equally spaced
  points: exact for orders below n / 2);
* mesh stiffness between the two torques, ``(F_hi - F_lo) / (TE_hi - TE_lo)`` on the period means,
  within 3 % (``F = T / r_b2``).
Helical pairs: mean TE and stiffness within 5 %.
"""
from __future__ import annotations

import math

import numpy as np

from gearrom.errors import ModelError
from gearrom.spectral import line_amplitudes

__all__ = ["SPUR_LIMITS", "HELICAL_LIMITS", "curve_metrics", "static_gate"]

SPUR_LIMITS = {"mean_te": 0.02, "rms_difference": 0.03, "gmf1": 0.05, "gmf2": 0.10, "gmf3": 0.10, "stiffness": 0.03}
HELICAL_LIMITS = {"mean_te": 0.05, "stiffness": 0.05}


def curve_metrics(te: np.ndarray) -> dict:
    """Mean and GMF1-3 amplitudes (m) of a static TE curve sampled at ``n`` equal steps over one mesh period."""
    x = np.asarray(te, float)
    if x.ndim != 1 or x.size < 8:
        raise ModelError(f"a static TE curve needs >= 8 points over the mesh period, got {x.shape}")
    amp = line_amplitudes(x, 2 * np.pi * np.arange(x.size) / x.size, (1, 2, 3))
    return {"mean": float(x.mean()), **{f"gmf{m}": float(a) for m, a in zip((1, 2, 3), amp)}}


def static_gate(te_fe: dict, te_ltca: dict, rb2: float, helical: bool = False) -> dict:
    """Compare static TE curves (torque [N m] -> array over one mesh period [m]) of the FE and the LTCA.

    Returns per torque the metrics and relative errors, the stiffness between the lowest and highest
    torque, ``passed`` and ``misses`` (each failed limit with its value).
    """
    limits = HELICAL_LIMITS if helical else SPUR_LIMITS
    torques = sorted(te_fe)
    if sorted(te_ltca) != torques or len(torques) < 2:
        raise ModelError(f"static gate needs the same >= 2 torques on both sides, got {sorted(te_fe)} and {sorted(te_ltca)}")
    out: dict = {"limits": limits, "torques_Nm": torques, "per_torque": {}}
    misses = []
    for t in torques:
        a, b = np.asarray(te_fe[t], float), np.asarray(te_ltca[t], float)
        if a.shape != b.shape:
            raise ModelError(f"static gate at {t:g} N m: {a.size} FE points against {b.size} LTCA points")
        ma, mb = curve_metrics(a), curve_metrics(b)
        row = {"fe_um": {k: v * 1e6 for k, v in ma.items()}, "ltca_um": {k: v * 1e6 for k, v in mb.items()},
               "rel_error": {k: ma[k] / mb[k] - 1.0 for k in ma},
               "rms_difference_rel": float(np.sqrt(np.mean((a - b) ** 2)) / abs(mb["mean"]))}
        checks = {"mean_te": row["rel_error"]["mean"], "rms_difference": row["rms_difference_rel"],
                  **{f"gmf{m}": row["rel_error"][f"gmf{m}"] for m in (1, 2, 3)}}
        for key, val in checks.items():
            if key in limits and not abs(val) <= limits[key]:
                misses.append(f"{t:g} N m {key}: {100 * val:+.1f} % (limit {100 * limits[key]:g} %)")
        out["per_torque"][f"{t:g}"] = row
    lo, hi = torques[0], torques[-1]
    df = (hi - lo) / rb2

    def stiff(curves):
        return df / (float(np.mean(curves[hi])) - float(np.mean(curves[lo])))

    k_fe, k_lt = stiff(te_fe), stiff(te_ltca)
    out["stiffness_N_per_um"] = {"fe": k_fe * 1e-6, "ltca": k_lt * 1e-6, "rel_error": k_fe / k_lt - 1.0,
                                 "between_Nm": [lo, hi]}
    if not abs(k_fe / k_lt - 1.0) <= limits["stiffness"]:
        misses.append(f"stiffness {lo:g}-{hi:g} N m: {100 * (k_fe / k_lt - 1):+.1f} % (limit "
                      f"{100 * limits['stiffness']:g} %)")
    out.update(passed=not misses, misses=misses)
    if not all(math.isfinite(v) for v in (k_fe, k_lt)):
        raise ModelError("static gate: the mean TE does not change between the torques")
    return out
