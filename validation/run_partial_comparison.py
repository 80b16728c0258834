"""An early look at a loaded-start helical reference that is still running: its record so far, read from the
checkpoint, against the exudyn pair ROM of ``gearrom validate``.

A reference takes many sittings; this tells, long before it ends, whether its comparison is heading for a pass
and which mesh orders decide it. The record so far is written as a provisional record (same arrays and keys as
the finished one, :func:`run_explicit_helical.main_loaded`) into a scratch folder and judged by
:func:`gearrom.validation.report.validate` on whole mesh periods after ``--settle`` periods. The start
transient has not settled in a short record, so the gates and metrics are indicative only; the period-to-period
RMS differences of the TE show how fast it decays (one per recorded period after the first).

Usage: ``python validation/run_partial_comparison.py RPM [--config thesis-helical] [--settle N]``

Needs the reference's checkpoint (``validation/checkpoints/<record>.ckpt.npz``) and builds its model once
(a few minutes on one core: the nodal masses give the output inertia the ROM takes). Writes
``validation/checkpoints/<record>.partial.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
import tempfile
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from gearrom.fe.explicit.driver import prepare
from gearrom.fe.explicit.gearpair import polar_inertias, transmission_error
from gearrom.fe.explicit.helicalpair import helical_pair_model
from gearrom.fe.explicit.result import ENERGY_NAMES
from gearrom.validation.records import pair_key
from run_explicit_helical import HERE, loaded_case

log = logging.getLogger("run_partial_comparison")
SAMPLES_PER_PERIOD = 128


def period_differences(te: np.ndarray, per: int = SAMPLES_PER_PERIOD) -> list[float]:
    """RMS difference [m] of each whole period of ``te`` from the one before: zero for a periodic response,
    the size of the transient times |1 - exp(-T / tau + i w T)| for a free vibration decaying with tau."""
    n = te.size // per
    return [float(np.sqrt(np.mean((te[k * per:(k + 1) * per] - te[(k - 1) * per:k * per]) ** 2)))
            for k in range(1, n)]


def main(rpm: float, config: str = "thesis-helical", settle: int = 1, out: Path | None = None) -> Path:
    from gearrom.validation.report import validate

    case = loaded_case(rpm, config=config)
    if not case.checkpoint.is_file():
        sys.exit(f"{case.checkpoint}: no checkpoint of this reference (validation/run_explicit_helical.py "
                 f"{rpm:g} --config {config} starts it)")
    with np.load(case.checkpoint) as z:
        row = int(z["row"])
        t, theta, energies = z["out_t"][:row], z["out_th"][:row], z["out_E"][:row]
    if row // SAMPLES_PER_PERIOD < settle + 1:
        sys.exit(f"{case.checkpoint}: the record so far holds {row // SAMPLES_PER_PERIOD} whole mesh periods; "
                 f"--settle {settle} leaves none to judge")
    model, info = helical_pair_model(case.pair, case.meshes, case.setup, case.mesh["n_layers"], run_angle=None)
    d = prepare(model, 0.9, case.mesh["max_candidates"])
    j1, j2 = polar_inertias(model, d["mass"], info["n_nodes_gear1"])
    te = transmission_error(SimpleNamespace(theta=theta), info["rb"], info["clearance_angle"])
    meta = {"config": case.cfg.name, "pair_key": pair_key(case.pair), "rpm_in": rpm, "torque_out_Nm": 120.0,
            "mu": 0.0, "start": "loaded", "mesh_frequency_Hz": case.f_mesh, "ramp_s": 0.0,
            "t_steady_from_s": settle / case.f_mesh, "t_end_s": float(t[-1]), "settle_periods": settle,
            "integration": "full", "outline_size_mm": case.mesh["outline_size_m"] * 1e3,
            "body_size_mm": case.mesh["body_size_m"] * 1e3, "grading_mm": case.mesh["grading_m"] * 1e3,
            "zeta_target": case.zeta, "relative_damping_per_s": case.alpha, "inertia_in_kgm2": j1,
            "inertia_out_kgm2": j2, "partial": True}
    with tempfile.TemporaryDirectory() as tmp:
        stem = Path(tmp) / case.stem.name
        np.savez_compressed(stem.with_suffix(".npz"), t_s=t, te_m=te, theta_rad=theta,
                            **{f"energy_{k}": energies[:, j] for j, k in enumerate(ENERGY_NAMES)})
        stem.with_suffix(".json").write_text(json.dumps(meta, default=float))
        speed = validate(config, [rpm], fe_dir=tmp).speeds[0]
    diffs = period_differences(te)
    result = {"record": case.stem.name, "t_reached_s": float(t[-1]), "t_end_s": case.t_end,
              "mesh_periods_so_far": row // SAMPLES_PER_PERIOD, "settle_periods_judged_from": settle,
              "period_difference_rms_um": [x * 1e6 for x in diffs],
              "decay_per_period_expected": float(np.exp(-1.0 / (case.f_mesh * case.tau))),
              "comparison": speed.to_dict()}
    out = Path(out) if out is not None else HERE / "checkpoints" / (case.stem.name + ".partial.json")
    out.write_text(json.dumps(result, indent=1, default=float) + "\n")
    m = speed.metrics
    log.info("%s at t = %.4g ms: DTE RMS ROM %.4f / FE %.4f um, GMF1 %.4f / %.4f um, misses %s; period "
             "differences %s um", case.stem.name, t[-1] * 1e3, m["dte_periodic_rms_um"]["rom"],
             m["dte_periodic_rms_um"]["fe"], m["gmf1_amplitude_um"]["rom"], m["gmf1_amplitude_um"]["fe"],
             speed.misses, np.round(np.array(diffs) * 1e6, 4).tolist())
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rpm", type=float)
    ap.add_argument("--config", default="thesis-helical", help="the helical pair of the reference")
    ap.add_argument("--settle", type=int, default=1, help="mesh periods left out before the judged window")
    ap.add_argument("--out", type=Path, default=None, help="JSON file (default: next to the checkpoint)")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # the seed pair's marginal tip-fillet interference
        main(a.rpm, a.config, a.settle, a.out)
