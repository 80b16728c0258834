"""Reference explicit FE runs of the seed's spur pair (2D plane strain Q4), 120 N m on the output.

Usage: ``python validation/run_explicit_spur.py RPM [PERIODS] [--start loaded] [--integration full] [--parallel]
[--settle N] [--wall-limit-h H]``.

``--start loaded`` (the validation reference): the pair starts from its loaded static state at the
start position (dynamic relaxation of the same model), each gear at its rigid-body speed, the full
output torque from t = 0, with the relative damping of ``validation/ringdown_spur.json`` (the ring-down
calibration: damping ratio zeta at the mesh mode, on the velocity relative to each gear's rigid
rotation, so the spin is not braked). It settles for ``--settle`` mesh periods (default: the periods
covering 5 time constants 1 / (zeta w_mesh-mode), after which the start transient is below 1 % of its
size) and records PERIODS (default 10). It writes ``spur_<rpm>rpm_loaded.npz/.json``.

The run writes a checkpoint ``validation/checkpoints/<stem>.ckpt.npz`` every few minutes; run the same
command again to resume it bit for bit (``--wall-limit-h`` stops a sitting cleanly after a checkpoint).
A finished or stopped run given a larger ``--settle`` or PERIODS continues from its checkpoint to the
later end (same chunk length: 1/8 mesh period), bit for bit the longer run.

``--start gap`` (the older records ``spur_<rpm>rpm[_full].*``): both gears at speed, a 1 um gap, the output
torque ramped in over ``--ramp-ms``, no damping. The quasi-static 60 rpm check is
``python validation/run_explicit_spur.py 60 1 --settle 0 --ramp-ms 5 --mass-scaling-dt 2.5e-8``.

Frictionless flanks (mu = 0; the seed used 0.1, which the ROM does not model), no extra inertia on the
reference nodes (the gear bodies alone, as in the seed's FE). The mesh is the all-quad gmsh mesh with
0.15 mm outline elements whose outline nodes lie on the generated profile; the loaded-start references
use the mesh of ``validation/ringdown_spur.json`` (tooth-periodic, refined outline).
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
from gearrom.errors import RunInterrupted
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.gearpair import GearPairSetup, run_gear_pair
from gearrom.fe.explicit.result import ENERGY_NAMES

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_explicit_spur")


def _reference_meshes(pair, cal: dict):
    from run_ringdown import reference_meshes

    return reference_meshes(pair, cal["mesh"])


def main(rpm: float, outline: float = 0.15e-3, body: float = 1.5e-3, periods: int = 10, settle_periods: int | None = None,
         ramp: float = 0.3e-3, mass_scaling_dt: float = 0.0, integration: str = "reduced",
         parallel: bool = False, start: str = "gap", wall_limit: float | None = None) -> Path:
    pair = load_config("thesis-spur").pair
    f_mesh = rpm / 60 * pair.z[0]
    extra = {}
    if start == "loaded":
        from run_ringdown import calibration, settling

        cal = calibration("spur")
        meshes = _reference_meshes(pair, cal)
        outline, body, mass_scaling_dt = (cal["mesh"][k] for k in ("outline_size_m", "body_size_m", "mass_scaling_dt_s"))
        alpha, zeta, f_mode, tau, settle_default = settling(cal, f_mesh)
        if settle_periods is None:
            settle_periods = settle_default
        ramp = 0.0
        setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, mu=0.0, integration=integration, start="loaded",
                              relative_damping=alpha, mass_scaling_dt=mass_scaling_dt,
                              penalty_scale=cal["mesh"]["penalty_scale"])
        stem = HERE / f"spur_{int(rpm)}rpm_loaded"
        extra = {"relative_damping_per_s": alpha, "zeta_target": zeta, "zeta_measured": cal["zeta_measured"],
                 "mesh_mode_Hz": f_mode, "decay_time_s": tau, "outline_sag_um": cal["mesh"]["sag_m"] * 1e6,
                 "penalty_scale": cal["mesh"]["penalty_scale"], "periodic_mesh": cal["mesh"].get("periodic", False),
                 "inertia_out_kgm2": None, "inertia_in_kgm2": None}
    else:
        meshes = [gear_quad_mesh(pair, i, outline, body) for i in (0, 1)]
        settle_periods = 1 if settle_periods is None else settle_periods
        setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=ramp, mu=0.0,
                              mass_scaling_dt=mass_scaling_dt, integration=integration)
        stem = HERE / (f"spur_{int(rpm)}rpm" + ("" if integration == "reduced" else f"_{integration}"))
    t_end = ramp + (settle_periods + periods) / f_mesh
    checkpoint = HERE / "checkpoints" / (stem.name + ".ckpt.npz")
    chunks = 8 * (settle_periods + periods)          # progress and a possible checkpoint every 1/8 period
    t0 = time.perf_counter()
    try:
        res, te, info = run_gear_pair(pair, meshes, setup, t_end=t_end, sample_period=1.0 / (f_mesh * 128),
                                      parallel=parallel, checkpoint=checkpoint, chunks=chunks,
                                      checkpoint_every=300.0, wall_limit=wall_limit)
    except RunInterrupted as exc:
        log.info("%s", exc)
        sys.exit(3)
    wall = time.perf_counter() - t0
    t_start = ramp + settle_periods / f_mesh
    for key in ("inertia_out_kgm2", "inertia_in_kgm2"):
        if key in extra:
            extra[key] = res.meta[key]
    np.savez_compressed(stem.with_suffix(".npz"), t_s=res.t, te_m=te, theta_rad=res.theta,
                        **{f"energy_{k}": res.energies[:, j] for j, k in enumerate(ENERGY_NAMES)})
    meta = {
        "config": "thesis-spur", "rpm_in": rpm, "torque_out_Nm": 120.0, "mu": 0.0, "start": start,
        "mesh_frequency_Hz": f_mesh, "ramp_s": ramp, "t_steady_from_s": t_start, "t_end_s": t_end,
        "settle_periods": settle_periods, "mesh_periods_recorded": periods, "integration": integration,
        "threads": 2 if parallel else 1, "outline_size_mm": outline * 1e3, "body_size_mm": body * 1e3,
        "outline_on_profile": True, "flank_spacing_mm": info["flank_spacing_m"] * 1e3,
        "n_elements": res.meta["n_elements"], "n_nodes": res.meta["n_nodes"], "dt_s": res.meta["dt_s"],
        "n_steps": res.meta["n_steps"], "wall_s": res.meta["wall_time_s"], "wall_this_sitting_s": wall,
        "mass_scaling_dt_s": mass_scaling_dt, "added_mass_kg": res.meta.get("added_mass_kg", 0.0),
        "hourglass_ratio": res.hourglass_ratio, "energy_error": res.energy_error, **extra,
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()},
        "te_definition": "rb1*theta1 - rb2*theta2 on the line of action, m, positive when the output lags",
    }
    stem.with_suffix(".json").write_text(json.dumps(meta, indent=2, default=float) + "\n")
    return stem


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rpm", type=float)
    ap.add_argument("periods", type=int, nargs="?", default=10)
    ap.add_argument("--start", choices=("gap", "loaded"), default="gap", help="initial state (module docstring)")
    ap.add_argument("--settle", type=int, default=None, help="mesh periods discarded before the record")
    ap.add_argument("--ramp-ms", type=float, default=0.3, help="output torque ramp of the 'gap' start, ms")
    ap.add_argument("--mass-scaling-dt", type=float, default=0.0, help="selective mass scaling target step, s")
    ap.add_argument("--integration", choices=("reduced", "full"), default="reduced",
                    help="element integration; 'full' writes spur_<rpm>rpm_full.* (no hourglass energy)")
    ap.add_argument("--parallel", action="store_true", help="multi-threaded loop (both cores)")
    ap.add_argument("--wall-limit-h", type=float, default=None,
                    help="stop after a checkpoint once this many hours have passed (exit code 3); rerun to resume")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    main(a.rpm, periods=a.periods, settle_periods=a.settle, ramp=a.ramp_ms * 1e-3, mass_scaling_dt=a.mass_scaling_dt,
         integration=a.integration, parallel=a.parallel, start=a.start,
         wall_limit=None if a.wall_limit_h is None else a.wall_limit_h * 3600)
