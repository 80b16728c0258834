"""Reference explicit FE runs of the seed's helical pair (3D Hex8), 120 N m on the output.

Usage: ``python validation/run_explicit_helical.py RPM [PERIODS] [--integration full|reduced] [--parallel]``
(writes validation/helical_<rpm>rpm.npz/.json, ``_full`` appended for fully integrated elements; PERIODS
recorded mesh periods after settling, default 5).

Set-up as the spur reference (validation/run_explicit_spur.py): both gears start at speed, the output torque
ramps in over 0.3 ms, one mesh period settles, then PERIODS mesh periods are recorded; frictionless flanks,
no extra inertia on the reference nodes. Mesh (coarser than the spur, as the issue allows): the transverse
all-quad mesh with 0.3 mm outline elements (outline nodes on the generated profile: 0.3 mm chords),
2.5 mm body elements from 1 mm below the outline, extruded in 8 twisted layers (2.25 mm) over the 18 mm
common face width, each gear cut to the sector that meshes during the run (the removed inertia is added to
its reference node); selective mass scaling to a 2.2e-8 s step (the added mass is in the metadata);
contact penalty factor 0.1. Default elements: fully integrated Hex8 (2x2x2 Gauss, no hourglass modes; the
one-point Hex8 with hourglass stiffness 0.1 is too soft under the nodal contact forces of this mesh, as the
one-point Q4 was in 2D).
This is a long job (about half an hour per speed on one core): run it in the background.

The 3D contact's open-edge rule (gearrom.fe.explicit.contact.contact_forces_3d) keeps slave nodes that pass
the cut ends of the master flanks from creating energy (see the gearrom.fe.explicit.helicalpair module notes).
"""
from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.explicit.gearpair import GearPairSetup
from gearrom.fe.explicit.helicalpair import helical_meshes, run_helical_pair
from gearrom.fe.explicit.result import ENERGY_NAMES

HERE = Path(__file__).resolve().parent

#: mesh and step of the committed references (the validation report rebuilds the output inertia from them)
OUTLINE, BODY, GRADING, LAYERS, MASS_SCALING_DT = 0.3e-3, 2.5e-3, 1.0e-3, 8, 2.2e-8
#: 3D contact penalty and hourglass stiffness (the spur's 0.3 penalty made the 3D node-to-facet contact
#: pump energy in bursts under load; 0.1 keeps the energy balance, with little change of the TE)
PENALTY, HOURGLASS = 0.1, 0.1
#: output layer planes half a layer off the input's: with matching planes every contact node sits on a master
#: facet crease, and switching between the two facets' normals pumped energy into the run in bursts
STAGGER = False


def main(rpm: float, periods: int = 5, settle_periods: int = 1, out_dir: Path = HERE,
         t_end: float | None = None, integration: str = "full", parallel: bool = False) -> Path:
    """Run one speed and write ``helical_<rpm>rpm.npz/.json`` into ``out_dir``; ``t_end`` overrides the length."""
    pair = load_config("thesis-helical").pair
    meshes = helical_meshes(pair, OUTLINE, BODY, GRADING)
    f_mesh = rpm / 60 * pair.z[0]
    ramp = 0.3e-3
    t_end = t_end or ramp + (settle_periods + periods) / f_mesh
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=ramp, mu=0.0,
                          mass_scaling_dt=MASS_SCALING_DT, penalty_scale=PENALTY, hourglass_stiffness=HOURGLASS,
                          integration=integration)
    t0 = time.perf_counter()
    res, te, info = run_helical_pair(pair, meshes, setup, t_end=t_end, sample_period=1.0 / (f_mesh * 128),
                                     n_layers=LAYERS, parallel=parallel, stagger=STAGGER)
    wall = time.perf_counter() - t0
    stem = Path(out_dir) / (f"helical_{int(rpm)}rpm" + ("" if integration == "reduced" else f"_{integration}"))
    t_start = ramp + settle_periods / f_mesh
    np.savez_compressed(stem.with_suffix(".npz"), t_s=res.t, te_m=te, theta_rad=res.theta,
                        **{f"energy_{k}": res.energies[:, j] for j, k in enumerate(ENERGY_NAMES)})
    meta = {
        "config": "thesis-helical", "rpm_in": rpm, "torque_out_Nm": 120.0, "mu": 0.0,
        "mesh_frequency_Hz": f_mesh, "ramp_s": ramp, "t_steady_from_s": t_start, "t_end_s": float(res.t[-1]),
        "mesh_periods_recorded": periods, "outline_size_mm": OUTLINE * 1e3, "body_size_mm": BODY * 1e3,
        "grading_mm": GRADING * 1e3, "n_layers": LAYERS, "layer_mm": info["layer_m"] * 1e3,
        "face_width_mm": info["width_m"] * 1e3, "flank_spacing_mm": info["flank_spacing_m"] * 1e3,
        "layer_rigid_slack_spread_um": float(np.ptp(info["layer_slack_m"]) * 1e6),
        "n_elements": res.meta["n_elements"], "n_nodes": res.meta["n_nodes"], "dt_s": res.meta["dt_s"],
        "dt_stable_s": res.meta["dt_stable_s"], "mass_scaling_dt_s": MASS_SCALING_DT,
        "added_mass_kg": res.meta["added_mass_kg"], "total_mass_kg": res.meta["total_mass_kg"],
        "n_steps": res.meta["n_steps"], "wall_s": wall, "penalty_scale": PENALTY, "hourglass_stiffness": HOURGLASS,
        "staggered_layers": STAGGER,
        "sector_model": True, "removed_inertia_kgm2": info["removed_inertia_kgm2"],
        "ns_per_element_step": wall / (res.meta["n_steps"] * res.meta["n_elements"]) * 1e9,
        "integration": integration, "threads": 2 if parallel else 1,
        "start_gap_loa_um": float(info["start_gap_loa_m"][-1] * 1e6),
        "hourglass_ratio": res.hourglass_ratio, "energy_error": res.energy_error,
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()},
        "te_definition": "rb1*theta1 - rb2*theta2 on the transverse line of action (transverse base radii), m, "
                         "positive when the output lags",
    }
    stem.with_suffix(".json").write_text(json.dumps(meta, indent=2, default=float) + "\n")
    return stem


if __name__ == "__main__":
    import argparse
    import logging

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rpm", type=float)
    ap.add_argument("periods", type=int, nargs="?", default=5)
    ap.add_argument("--integration", choices=("reduced", "full"), default="full",
                    help="element integration; 'full' (default) writes helical_<rpm>rpm_full.*")
    ap.add_argument("--parallel", action="store_true", help="multi-threaded loop (both cores)")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    main(a.rpm, periods=a.periods, integration=a.integration, parallel=a.parallel)
