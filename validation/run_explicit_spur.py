"""Reference explicit FE runs of the seed's spur pair (2D plane strain Q4), 120 N m on the output.

Usage: ``python validation/run_explicit_spur.py RPM [PERIODS] [--settle N] [--ramp-ms T] [--mass-scaling-dt S]``
(writes validation/spur_<rpm>rpm.npz/.json; PERIODS recorded mesh periods after settling, default 10;
``--integration full`` uses fully integrated Q4 without hourglass modes and writes spur_<rpm>rpm_full.*;
``--parallel`` runs the multi-threaded loop).

The quasi-static check of the issue is the 60 rpm run
``python validation/run_explicit_spur.py 60 1 --settle 0 --ramp-ms 5 --mass-scaling-dt 2.5e-8``: selective
mass scaling (only the fine outline nodes, added mass reported) lifts the stable step 7x; the mesh mode
stays far above the 32 Hz mesh frequency, so the run is quasi-static (no damping is added: mass damping
would brake the rotating gears).

Both gears start at speed; the output torque ramps in over 0.3 ms (instead of the seed's speed ramp of
0.35-0.5 ms: starting at speed avoids the impact the seed's ramp was there to soften), then one mesh
period settles and ten mesh periods are recorded (issue: >= 10 after settling). Frictionless flanks
(mu = 0; the seed used 0.1, which the ROM does not model), no extra inertia on the reference nodes
(the gear bodies alone, as in the seed's FE). The mesh is the all-quad gmsh mesh with 0.15 mm
outline elements (the rigid-geometry TE of that faceted outline stays within ~2 um).
This is a long job (tens of minutes per speed on one core): run it in the background.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.gearpair import GearPairSetup, run_gear_pair
from gearrom.fe.explicit.result import ENERGY_NAMES

HERE = Path(__file__).resolve().parent


def main(rpm: float, outline: float = 0.15e-3, body: float = 1.5e-3, periods: int = 10, settle_periods: int = 1,
         ramp: float = 0.3e-3, mass_scaling_dt: float = 0.0, integration: str = "reduced",
         parallel: bool = False) -> Path:
    pair = load_config("thesis-spur").pair
    meshes = [gear_quad_mesh(pair, i, outline, body) for i in (0, 1)]
    f_mesh = rpm / 60 * pair.z[0]
    t_end = ramp + (settle_periods + periods) / f_mesh
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=ramp, mu=0.0,
                          mass_scaling_dt=mass_scaling_dt, integration=integration)
    t0 = time.perf_counter()
    res, te, info = run_gear_pair(pair, meshes, setup, t_end=t_end, sample_period=1.0 / (f_mesh * 128),
                                  parallel=parallel)
    wall = time.perf_counter() - t0
    stem = HERE / (f"spur_{int(rpm)}rpm" + ("" if integration == "reduced" else f"_{integration}"))
    t_start = ramp + settle_periods / f_mesh
    np.savez_compressed(stem.with_suffix(".npz"), t_s=res.t, te_m=te, theta_rad=res.theta,
                        **{f"energy_{k}": res.energies[:, j] for j, k in enumerate(ENERGY_NAMES)})
    meta = {
        "config": "thesis-spur", "rpm_in": rpm, "torque_out_Nm": 120.0, "mu": 0.0,
        "mesh_frequency_Hz": f_mesh, "ramp_s": ramp, "t_steady_from_s": t_start, "t_end_s": t_end,
        "mesh_periods_recorded": periods, "integration": integration, "threads": 2 if parallel else 1,
        "outline_size_mm": outline * 1e3, "body_size_mm": body * 1e3,
        "flank_spacing_mm": info["flank_spacing_m"] * 1e3, "n_elements": res.meta["n_elements"],
        "n_nodes": res.meta["n_nodes"], "dt_s": res.meta["dt_s"], "n_steps": res.meta["n_steps"],
        "wall_s": wall, "mass_scaling_dt_s": mass_scaling_dt,
        "added_mass_kg": res.meta.get("added_mass_kg", 0.0), "hourglass_ratio": res.hourglass_ratio, "energy_error": res.energy_error,
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()},
        "te_definition": "rb1*theta1 - rb2*theta2 on the line of action, m, positive when the output lags",
    }
    stem.with_suffix(".json").write_text(json.dumps(meta, indent=2, default=float) + "\n")
    return stem


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rpm", type=float)
    ap.add_argument("periods", type=int, nargs="?", default=10)
    ap.add_argument("--settle", type=int, default=1, help="mesh periods discarded after the ramp")
    ap.add_argument("--ramp-ms", type=float, default=0.3, help="output torque ramp, ms")
    ap.add_argument("--mass-scaling-dt", type=float, default=0.0, help="selective mass scaling target step, s")
    ap.add_argument("--integration", choices=("reduced", "full"), default="reduced",
                    help="element integration; 'full' writes spur_<rpm>rpm_full.* (no hourglass energy)")
    ap.add_argument("--parallel", action="store_true", help="multi-threaded loop (both cores)")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    main(a.rpm, periods=a.periods, settle_periods=a.settle, ramp=a.ramp_ms * 1e-3, mass_scaling_dt=a.mass_scaling_dt,
         integration=a.integration, parallel=a.parallel)
