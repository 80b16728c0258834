"""Explicit FE of the seed's spur pair: a short coarse run at 2000 rpm, 120 Nm (2D plane strain Q4).

Not a validation reference run (>= 10 mesh periods on the quasi-static FE meshes): one mesh period
after a 0.3 ms torque ramp, on an all-quad gmsh mesh with 0.15 mm outline elements (the rigid TE
of that faceted geometry stays within ~2 um; 0.3 mm gives ~10 um and tip interference). Both
gears start at speed. Writes the figures (TE statistics, energies, hourglass ratio, wall time,
time step, mesh size) to benchmarks/results/bench_explicit_gearpair.json and the histories to
benchmarks/results/bench_explicit_gearpair.npz/.json (ExplicitResult.save).
"""
from __future__ import annotations

import os
import time

import numpy as np

from _common import RESULTS, peak_memory_MB, write_result
from gearrom.config import load_config
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.gearpair import GearPairSetup, run_gear_pair


def main(rpm: float = 2000.0, outline: float = 0.15e-3, body: float = 1.5e-3) -> None:
    pair = load_config("thesis-spur").pair
    meshes = [gear_quad_mesh(pair, i, outline, body) for i in (0, 1)]
    f_mesh = rpm / 60 * pair.z[0]
    ramp = 0.3e-3
    t_end = ramp + 1.0 / f_mesh
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=ramp)
    t0 = time.perf_counter()
    res, te, info = run_gear_pair(pair, meshes, setup, t_end=t_end, sample_period=2e-6)
    wall = time.perf_counter() - t0
    res.save(RESULTS / "bench_explicit_gearpair")
    sel = res.t >= ramp
    te_um = te[sel] * 1e6
    figures = {
        "rpm_in": rpm, "torque_out_Nm": 120.0, "mesh_frequency_Hz": f_mesh,
        "outline_size_mm": outline * 1e3, "body_size_mm": body * 1e3,
        "flank_spacing_mm": info["flank_spacing_m"] * 1e3,
        "n_elements": res.meta["n_elements"], "n_nodes": res.meta["n_nodes"],
        "dt_s": res.meta["dt_s"], "n_steps": res.meta["n_steps"], "simulated_s": res.meta["t_end_s"],
        "wall_s": wall, "wall_per_simulated_s": wall / res.meta["t_end_s"],
        "element_updates_per_s": res.meta["element_updates_per_s"], "parallel": res.meta["parallel"],
        "te_mean_um": float(te_um.mean()), "te_ptp_um": float(np.ptp(te_um)),
        "te_rms_um": float(np.sqrt(np.mean((te_um - te_um.mean()) ** 2))),
        "hourglass_ratio": res.hourglass_ratio, "hourglass_dissipation_ratio": res.hourglass_dissipation_ratio,
        "energy_error": res.energy_error,
        "peak_memory_MB": peak_memory_MB(), "load_average_1_5_15": list(os.getloadavg()),
        "note": "one mesh period after the ramp only; 2 cores shared with other helpers",
    }
    write_result("bench_explicit_gearpair", figures)


if __name__ == "__main__":
    main()
