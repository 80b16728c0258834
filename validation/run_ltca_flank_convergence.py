"""Convergence of the spur LTCA's static TE harmonics in its flank element size, against the explicit model.

The static gate (``run_static_gate.py``) compares the explicit spur model's static TE with the LTCA
table at 16 angles and 60 / 120 N m. This study solves the LTCA (:func:`gearrom.fe.sweep.stiffness_sweep`,
64 positions) with the flank grid of the default ``MeshSettings.flank_size`` and with half and a quarter of
it, reads each table at the gate's 16 angles, and gives the mean and GMF1-3 of the static TE next to the
explicit model's, and the gate's verdict with each table, from a static gate result file (default: the periodic 0.5 mm body, 0.1 um sag, penalty
2 study). The flank grid resolves the tip-edge rounding where contact starts and ends, which sets the
GMF harmonics more than the mean.

Usage::

    python validation/run_ltca_flank_convergence.py [--gate FILE] [--flank-mm 0.025 0.0125 0.00625]

Writes ``validation/ltca_flank_convergence_<gate file stem>.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import platform
import time
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.sweep import stiffness_sweep
from gearrom.spectral import line_amplitudes
from gearrom.validation.pair_rom import fe_start_mesh_phase
from gearrom.validation.static_gate import static_gate

HERE = Path(__file__).resolve().parent
GATE = HERE / "static_gate_spur_sag0.1um_penalty2_body0.5mm_periodic.json"
log = logging.getLogger("run_ltca_flank_convergence")


def harmonics(x: np.ndarray, n: int = 3) -> list[float]:
    """Amplitudes of harmonics 1..n of one period sampled uniformly (um in, um out)."""
    return line_amplitudes(x, 2 * np.pi * np.arange(x.size) / x.size, range(1, n + 1)).tolist()


def main(gate: Path = GATE, flank_mm=(0.025, 0.0125, 0.00625)) -> Path:
    pair = load_config("thesis-spur").pair
    fe_pts = json.loads(gate.read_text())
    n = int(fe_pts["n_points"])
    torques = [float(t) for t in fe_pts["ltca_um"]]
    period = 2 * math.pi / pair.z[0]
    th = np.mod(fe_start_mesh_phase(pair) + np.arange(n) * period / n, period)
    out = {"gate_file": gate.name, "n_points": n, "torques_Nm": torques, "explicit": {}, "ltca": {},
           "machine": platform.node()}
    for t in torques:
        fe = np.array([fe_pts["points"][f"{t:g}Nm/{j}"]["te_um"] for j in range(n)])
        out["explicit"][f"{t:g}"] = {"mean_um": float(fe.mean()), "gmf_um": harmonics(fe)}
    for f in flank_mm:
        t0 = time.perf_counter()
        ex = stiffness_sweep(pair, torques, 64, settings=MeshSettings(flank_size=f * 1e-3)).to_excitation()
        row = {"solve_s": time.perf_counter() - t0}
        fe_m = {t: np.array([fe_pts["points"][f"{t:g}Nm/{j}"]["te_um"] for j in range(n)]) * 1e-6 for t in torques}
        row["gate"] = static_gate(fe_m, {t: np.asarray(ex.ste(th, t), float) for t in torques}, pair.rb[1])
        for t in torques:
            lt = np.asarray(ex.ste(th, t), float) * 1e6
            fe = out["explicit"][f"{t:g}"]
            row[f"{t:g}"] = {"mean_um": float(lt.mean()), "gmf_um": harmonics(lt),
                             "explicit_over_ltca_minus_1": {"mean": fe["mean_um"] / float(lt.mean()) - 1,
                                                           "gmf": [a / b - 1 for a, b in zip(fe["gmf_um"], harmonics(lt))]}}
        out["ltca"][f"{f:g}mm"] = row
        log.info("flank %g mm: gate passed %s, misses %s", f, row["gate"]["passed"], row["gate"]["misses"])
    path = HERE / f"ltca_flank_convergence_{gate.stem}.json"
    path.write_text(json.dumps(out, indent=1, default=float) + "\n")
    return path


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gate", type=Path, default=GATE, help="static gate result file with the explicit points")
    ap.add_argument("--flank-mm", type=float, nargs="+", default=[0.025, 0.0125, 0.00625])
    a = ap.parse_args()
    log.info("written %s", main(a.gate, a.flank_mm))
