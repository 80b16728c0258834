"""Wall time per simulated second: explicit FE of the spur pair vs the pair ROM (target >= 1e4).

Both measured in this process on this machine: the explicit FE on the validation mesh (0.15 mm
outline, 1.5 mm body, 2000 rpm, 120 Nm) over a short window after a JIT warm-up (its cost per
step is constant: fixed mesh, fixed time step), and the pair ROM (1 DOF, RK4/numba, FE LTCA
mesh table) over the validation run length (0.3 ms ramp + 11 mesh periods), also after warm-up.
If the stored reference runs exist (validation/spur_<rpm>rpm.json) their wall_s / t_end_s is
reported too.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

from _common import peak_memory_MB, write_result
from gearrom.config import load_config
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.gearpair import GearPairSetup, run_gear_pair
from gearrom.validation.pair_rom import PairRomSetup, mesh_excitation, simulate_pair_rom
from gearrom.validation.report import output_inertia

VALIDATION = Path(__file__).resolve().parents[1] / "validation"


def main(rpm: float = 2000.0, fe_window: float = 40e-6) -> None:
    pair = load_config("thesis-spur").pair
    f_mesh = rpm / 60 * pair.z[0]
    # --- explicit FE, same mesh as the reference runs
    meshes = [gear_quad_mesh(pair, i, 0.15e-3, 1.5e-3) for i in (0, 1)]
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=0.3e-3, mu=0.0)
    run_gear_pair(pair, meshes, setup, t_end=1e-7, sample_period=1e-7, parallel=False)     # JIT warm-up
    t0 = time.perf_counter()
    res, _, _ = run_gear_pair(pair, meshes, setup, t_end=fe_window, sample_period=1e-6, parallel=False)
    fe_wall = time.perf_counter() - t0
    # --- pair ROM over the validation run length
    ex, label = mesh_excitation(pair, 120.0, "fe")
    j2, _ = output_inertia(pair, 0.15e-3, 1.5e-3)
    rs = PairRomSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=0.3e-3, inertia_out=j2)
    t_rom = 0.3e-3 + 11 / f_mesh
    simulate_pair_rom(pair, ex, rs, t_end=1e-4, sample_period=1 / (f_mesh * 128))              # JIT warm-up
    walls = []
    for _ in range(5):
        t0 = time.perf_counter()
        rom = simulate_pair_rom(pair, ex, rs, t_end=t_rom, sample_period=1 / (f_mesh * 128))
        walls.append(time.perf_counter() - t0)
    rom_wall = min(walls)
    fe_per_s = fe_wall / fe_window
    rom_per_s = rom_wall / t_rom
    figures = {
        "rpm_in": rpm, "fe_window_s": fe_window, "fe_wall_s": fe_wall, "fe_n_elements": res.meta["n_elements"],
        "fe_dt_s": res.meta["dt_s"], "fe_n_steps": res.meta["n_steps"], "fe_wall_per_simulated_s": fe_per_s,
        "rom_simulated_s": t_rom, "rom_wall_s": rom_wall, "rom_dt_s": rom.meta["dt_s"], "rom_n_steps": rom.meta["n_steps"],
        "rom_wall_per_simulated_s": rom_per_s, "ratio_fe_over_rom": fe_per_s / rom_per_s, "target_ratio": 1e4,
        "rom_excitation": label, "rom_model": rom.meta["model"],
        "load_average_1_5_15": list(os.getloadavg()), "peak_memory_MB": peak_memory_MB(),
        "note": ("serial explicit kernel; ROM = 1-DOF numba pair model (not the exudyn rig); "
                 "2 cores shared with other helpers and the lead's reference FE runs"),
    }
    for r in (1250, 2000):
        js = VALIDATION / f"spur_{r}rpm.json"
        if js.is_file():
            meta = json.loads(js.read_text())
            figures[f"stored_fe_{r}rpm_wall_per_simulated_s"] = meta["wall_s"] / meta["t_end_s"]
            figures[f"stored_fe_{r}rpm_ratio_over_rom"] = meta["wall_s"] / meta["t_end_s"] / rom_per_s
    write_result("bench_validation_ratio", figures)


if __name__ == "__main__":
    main()
