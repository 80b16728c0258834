"""Static check of the drawing micro-geometry in the explicit helical model against the 3D LTCA.

Usage: ``python benchmarks/bench_explicit_helical_micro.py [--outline-mm 0.5] [--layers 6] [--points 4]``

Both models of the seed's helical pair, perfect (thesis-helical) and with the drawing's tip relief, profile
and lead crowning and usable tip (thesis-helical-drawing), at 120 N m: the explicit model by direct static
solves (:class:`gearrom.fe.explicit.static3d.StaticPair3D`, penalty scale 3, tooth-periodic sections,
whole bodies) at ``--points`` input angles over one mesh period, the LTCA by the sweep's 3D FE table at the
same angles. Figures: each side's mean static TE and peak-to-peak, the change the drawing makes, and the
ratio explicit / LTCA of that change (1 when both carry the modifications alike). Writes
``benchmarks/results/bench_explicit_helical_micro_<outline>mm_<layers>layers.json``.
"""
from __future__ import annotations

import argparse
import logging
import math
import time
import warnings

import numpy as np

from _common import peak_memory_MB, write_result
from gearrom.config import load_config
from gearrom.fe.explicit.gearpair import GearPairSetup
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model
from gearrom.fe.explicit.static3d import StaticPair3D
from gearrom.validation.pair_rom import fe_start_mesh_phase, mesh_excitation

TORQUE = 120.0
PENALTY = 3.0


def _pair(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # the seed pair's marginal tip-fillet interference
        return load_config(name).pair


def main(outline: float, layers: int, n: int) -> dict:
    pairs = {"perfect": _pair("thesis-helical"), "drawing": _pair("thesis-helical-drawing")}
    period = 2 * math.pi / pairs["perfect"].z[0]
    th = np.arange(n) * period / n
    meshes = helical_meshes(pairs["perfect"], outline, 3e-3, 1e-3, periodic=True)
    figs = {"outline_size_mm": outline * 1e3, "n_layers": layers, "n_points": n, "torque_Nm": TORQUE,
            "penalty_scale": PENALTY}
    for name, pair in pairs.items():
        t0 = time.perf_counter()
        setup = GearPairSetup(rpm_in=1e-4, torque_out=TORQUE, penalty_scale=PENALTY, integration="full")
        model, info = helical_pair_model(pair, meshes, setup, layers)
        pts = StaticPair3D(model, info, pair).points(th, [TORQUE])
        fe = np.array([p.te for p in pts])
        ex, _ = mesh_excitation(pair, TORQUE, "fe")
        lt = np.asarray(ex.ste(np.mod(fe_start_mesh_phase(pair) + th, period), TORQUE), float)
        figs[name] = {"explicit_te_um": (fe * 1e6).round(4).tolist(), "ltca_te_um": (lt * 1e6).round(4).tolist(),
                      "explicit_mean_um": float(fe.mean() * 1e6), "ltca_mean_um": float(lt.mean() * 1e6),
                      "explicit_ptp_um": float(np.ptp(fe) * 1e6), "ltca_ptp_um": float(np.ptp(lt) * 1e6),
                      "wall_s": time.perf_counter() - t0}
        logging.info("%s: explicit mean %.3f um, LTCA mean %.3f um", name, fe.mean() * 1e6, lt.mean() * 1e6)
    d_fe = figs["drawing"]["explicit_mean_um"] - figs["perfect"]["explicit_mean_um"]
    d_lt = figs["drawing"]["ltca_mean_um"] - figs["perfect"]["ltca_mean_um"]
    figs.update(explicit_mean_change_um=d_fe, ltca_mean_change_um=d_lt, change_ratio_explicit_to_ltca=d_fe / d_lt,
                peak_memory_MB=peak_memory_MB())
    return figs


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--outline-mm", type=float, default=0.5)
    ap.add_argument("--layers", type=int, default=6)
    ap.add_argument("--points", type=int, default=4)
    a = ap.parse_args()
    f = main(a.outline_mm * 1e-3, a.layers, a.points)
    write_result(f"bench_explicit_helical_micro_{a.outline_mm:g}mm_{a.layers}layers", f)
