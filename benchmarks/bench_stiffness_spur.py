"""Benchmark: FE LTCA of the spur pair (thesis-spur) over one mesh cycle.

Figures: cold run (meshing + FE + influence coefficients + 64 contact positions at 120 N m, no
cache) against the 60 s budget; re-evaluation with a new torque and with a new micro-geometry
(same compliances, no FE) against 2 s; ISO 6336 ratios; peak memory. The 64 contact positions again
with the contact solves' BLAS at one thread (``SpurLTCA.solve_many``, the package's setting) and at
BLAS's own thread count, in the same run: the ratio that one thread gains on small dense solves, which
is largest when the other core is busy (the load average is recorded).

Run: python benchmarks/bench_stiffness_spur.py
"""
from __future__ import annotations

import dataclasses
import math
import os
import time

from _common import peak_memory_MB, write_result

from gearrom.config import load_config
from gearrom.fe.iso6336 import mesh_stiffness, single_stiffness
from gearrom.fe.ltca import SpurLTCA
from gearrom.fe.sweep import build_ltca, mesh_cycle


def blas_thread_ratio(pair, repeats: int = 3) -> dict:
    """Contact solves of 64 positions at 120 N m on the validation's flank grid (larger contact systems),
    with BLAS at one thread and at all threads, alternated ``repeats`` times after a warm-up (best of each)."""
    from threadpoolctl import threadpool_limits

    from gearrom.fe.mesh2d import MeshSettings
    from gearrom.validation.pair_rom import REFERENCE_FLANK_SIZE

    fine = build_ltca(pair, MeshSettings(flank_size=REFERENCE_FLANK_SIZE))
    theta = [i * fine.period / 64 for i in range(64)]
    for th in theta:                       # warm-up: compliance matrices cached
        fine.solve_many(th, [120.0])
    one, full = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for th in theta:
            fine.solve_many(th, [120.0])
        t1 = time.perf_counter()
        with threadpool_limits(limits=os.cpu_count(), user_api="blas"):
            for th in theta:
                fine._solve_many(th, [120.0], 0, None)   # the same solves without the one-thread limit
        one.append(t1 - t0)
        full.append(time.perf_counter() - t1)
    return {"contact_64_positions_fine_grid_blas_1_thread_s": min(one),
            "contact_64_positions_fine_grid_blas_all_threads_s": min(full),
            "blas_all_threads_over_1_thread": min(full) / min(one),
            "fine_grid_flank_mm": REFERENCE_FLANK_SIZE * 1e3}


def main() -> None:
    pair = load_config("thesis-spur").pair
    t0, c0 = time.perf_counter(), time.process_time()
    ltca = build_ltca(pair, cache_dir=None)
    t1, c1 = time.perf_counter(), time.process_time()
    res = mesh_cycle(ltca, [120.0], 64)
    t2, c2 = time.perf_counter(), time.process_time()
    new_torque = mesh_cycle(ltca, [60.0, 240.0], 64)
    t3 = time.perf_counter()
    gears = []
    for i, g in enumerate(pair.gears):
        d_ca = 2 * math.hypot(pair.rb[i], pair.roll_tip[i] - pair.pb_t)
        gears.append(dataclasses.replace(g, micro=dataclasses.replace(g.micro, enabled=True, tip_relief=10e-6,
                                                                       tip_relief_start_diameter=d_ca)))
    relieved = SpurLTCA(dataclasses.replace(pair, gears=tuple(gears)), ltca.c)
    res_relief = mesh_cycle(relieved, [120.0], 64)
    t4 = time.perf_counter()
    L_c = 0.5 * pair.dw[0] * math.sin(pair.alpha_wt)
    th = (L_c - pair.roll_start_active[0]) / pair.rb[0]
    p = int(math.floor(th / ltca.period))
    single = ltca.solve(th - p * ltca.period, 120.0, only=[p])
    s = res.summary(0)
    b = pair.face_width
    blas = blas_thread_ratio(pair)
    figures = {
        "cold_total_s": t2 - t0,
        "cold_fe_s": t1 - t0,
        "cold_contact_64_positions_s": t2 - t1,
        "cold_total_cpu_s": c2 - c0,
        "cold_fe_cpu_s": c1 - c0,
        "cold_contact_64_positions_cpu_s": c2 - c1,
        "load_average_1min": os.getloadavg()[0],
        "budget_cold_s": 60.0,
        "reeval_new_torques_s": t3 - t2,
        "reeval_new_microgeometry_s": t4 - t3,
        "budget_reeval_s": 2.0,
        **blas,
        "peak_memory_MB": peak_memory_MB(),
        "fe_info": [c.info for c in ltca.c],
        "mean_stiffness_N_per_um_120Nm": s["mean_stiffness_N_per_um"],
        "stiffness_ptp_N_per_um_120Nm": s["stiffness_ptp_N_per_um"],
        "ste_mean_um_120Nm": s["ste_mean_um"],
        "ste_ptp_um_120Nm": s["ste_ptp_um"],
        "max_contact_pressure_MPa_120Nm": s["max_contact_pressure_MPa"],
        "ratio_to_iso_c_gamma_alpha": s["mean_stiffness_N_per_um"] * 1e6 / (mesh_stiffness(pair) * b),
        "single_pair_stiffness_pitch_N_per_um": single.stiffness * 1e-6,
        "ratio_single_pair_to_iso_c_prime": single.stiffness / (single_stiffness(pair) * b),
        "ste_ptp_um_60_240Nm": [new_torque.summary(j)["ste_ptp_um"] for j in range(2)],
        "ste_ptp_um_120Nm_long_tip_relief_10um": res_relief.summary(0)["ste_ptp_um"],
        "note": ("wall times are upper bounds when the load average above exceeds ~1 (2 cores shared with other "
                 "jobs); the process CPU times (all threads of this process) are what this run itself used"),
    }
    write_result("bench_stiffness_spur", figures)


if __name__ == "__main__":
    main()
