"""Static TE of the helical 3D explicit model at the start position (dynamic relaxation), by contact penalty
and sector size: where the explicit model's extra compliance against the helical LTCA table comes from.

Usage: ``python validation/run_static_helical.py [RUN_ANGLE_RAD] [PENALTY]`` (appends one entry to
validation/static_helical.json). The mesh and elements are the references' (validation/run_explicit_helical.py:
0.3 mm transverse outline, 2.5 mm body, 8 layers, fully integrated Hex8, mass scaling to 2.2e-8 s); the input
is held (1e-4 rpm), the output torque (120 N m) ramps in over 0.2 ms, mass-proportional damping 4e4 1/s
removes the vibration, and the TE is averaged over 1.2-1.5 ms. ``RUN_ANGLE_RAD`` sets the sector each gear is
cut to (the angle a run covers; 0: only the meshing teeth and two teeth of margin each side); the reference
run at 2000 rpm covers 1.24 rad. One run: 9-14 min on one core.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.explicit.driver import prepare, solve
from gearrom.fe.explicit.gearpair import GearPairSetup, transmission_error
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model
from run_explicit_helical import BODY, GRADING, HOURGLASS, LAYERS, MASS_SCALING_DT, OUTLINE

HERE = Path(__file__).resolve().parent


def main(run_angle: float = 0.0, penalty: float = 0.1) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-helical").pair
    meshes = helical_meshes(pair, OUTLINE, BODY, GRADING)
    setup = GearPairSetup(rpm_in=1e-4, torque_out=120.0, torque_ramp_time=0.2e-3, penalty_scale=penalty,
                          hourglass_stiffness=HOURGLASS, mass_scaling_dt=MASS_SCALING_DT, integration="full",
                          mass_damping=4e4)
    t0 = time.perf_counter()
    model, info = helical_pair_model(pair, meshes, setup, LAYERS, run_angle=run_angle)
    res = solve(model, 1.5e-3, 5e-6, prepared=prepare(model, 0.9, 32), parallel=False)
    te = transmission_error(res, info["rb"], info["clearance_angle"])
    m = res.t > 1.2e-3
    return dict(run_angle_rad=run_angle, penalty_scale=penalty, n_elements=res.meta["n_elements"],
                te_static_um=float(te[m].mean() * 1e6), te_spread_um=float(np.ptp(te[m]) * 1e6),
                wall_s=time.perf_counter() - t0,
                machine={"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()})


if __name__ == "__main__":
    out = HERE / "static_helical.json"
    entry = main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.0, float(sys.argv[2]) if len(sys.argv) > 2 else 0.1)
    data = json.loads(out.read_text()) if out.is_file() else {"runs": []}
    data["runs"].append(entry)
    out.write_text(json.dumps(data, indent=2) + "\n")
