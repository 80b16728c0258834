"""Benchmark: helical pair of the rig (thesis-helical) with the 3D FE model over one mesh cycle.

Figures: cold run (meshing + assembly + factorisation + influence coefficients of both 3D gears +
64 positions at 120 N m with the tangent stiffness) against the 10 min budget; re-evaluation with a
new torque and with the drawing micro-geometry (no FE solve) against 2 s; peak memory; ISO 6336
ratio; STE mean / peak-to-peak without and with the drawing modifications (and each alone); the
second formulation (direct FE solve of both 3D gears under the LTCA forces) and the uncoupled
plane-strain slice model at 3 positions; contact pattern plot.

Run: python benchmarks/bench_stiffness_helical3d.py
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small dense contact problems: threads only stall

import dataclasses  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
from _common import RESULTS, peak_memory_MB, write_result  # noqa: E402

from gearrom.config import load_config  # noqa: E402
from gearrom.fe.ltca_slices import plot_contact_pattern  # noqa: E402
from gearrom.fe.iso6336 import mesh_stiffness  # noqa: E402
from gearrom.fe.sweep import build_ltca, mesh_cycle  # noqa: E402


def _micro(pair, **kw):
    gears = [dataclasses.replace(g, micro=dataclasses.replace(g.micro, enabled=True, **kw)) for g in pair.gears]
    return dataclasses.replace(pair, gears=tuple(gears))


def main() -> None:
    warnings.simplefilter("ignore")
    pair = load_config("thesis-helical").pair
    t0 = time.perf_counter()
    ltca = build_ltca(pair, cache_dir=None)  # 3D model, default mesh, no cache: everything from scratch
    t1 = time.perf_counter()
    res = mesh_cycle(ltca, [120.0], 64)
    t2 = time.perf_counter()
    res60 = mesh_cycle(ltca, [60.0], 64, tangent=False)
    t3 = time.perf_counter()
    drawing = ltca.with_pair(_micro(pair))
    resd = mesh_cycle(drawing, [120.0], 64, tangent=False)
    t4 = time.perf_counter()
    resc = mesh_cycle(ltca.with_pair(_micro(pair, tip_relief=0.0, profile_crowning=0.0, tip_form_diameter=None)),
                      [120.0], 64, tangent=False)
    resr = mesh_cycle(ltca.with_pair(_micro(pair, lead_crowning=0.0, profile_crowning=0.0, tip_form_diameter=None)),
                      [120.0], 64, tangent=False)
    plot_contact_pattern(ltca.solve(0.0, 120.0), pair).savefig(RESULTS / "bench_stiffness_helical3d_pattern.png", dpi=80)
    plot_contact_pattern(drawing.solve(0.0, 120.0), pair).savefig(
        RESULTS / "bench_stiffness_helical3d_pattern_drawing.png", dpi=80)
    mem_sweep = peak_memory_MB()
    # second formulation (direct FE solve) and the slice model at 3 positions
    from gearrom.fe.loaded3d import LoadedPair3D

    t5 = time.perf_counter()
    loaded = LoadedPair3D(ltca)
    slices = build_ltca(pair, cache_dir=None, helical_model="slices")
    cross = []
    for frac in (0.0, 0.33, 0.71):
        th = frac * ltca.period
        c = loaded.crosscheck(th, 120.0)
        sl = slices.solve(th, 120.0)
        cross.append({"theta_over_period": frac, "ste_ltca_um": c["ste_ltca"] * 1e6, "ste_direct_um": c["ste_direct"] * 1e6,
                      "ste_direct_over_ltca": c["ste_direct"] / c["ste_ltca"],
                      "k_ltca_N_per_um": c["stiffness_ltca"] * 1e-6, "k_direct_N_per_um": c["stiffness_direct"] * 1e-6,
                      "ste_slices_um": sl.ste * 1e6, "k_slices_N_per_um": sl.stiffness * 1e-6})
    loaded.write_vtu(0.0, 120.0, RESULTS / "bench_stiffness_helical3d.vtu")
    t6 = time.perf_counter()
    s, sd = res.summary(0), resd.summary(0)
    iso = mesh_stiffness(pair) * pair.face_width
    figures = {
        "model": ltca.model_description,
        "dofs": [c.info["dofs"] for c in ltca.c], "solver": ltca.c[0].info["solver"],
        "fe_times_s": [{k: c.info[k] for k in ("time_mesh_s", "time_factorise_s", "time_influence_s")} for c in ltca.c],
        "cold_total_s": t2 - t0, "cold_fe_s": t1 - t0, "cold_sweep_64_positions_with_tangent_s": t2 - t1,
        "budget_cold_s": 600.0,
        "reeval_new_torque_s": t3 - t2, "reeval_drawing_microgeometry_s": t4 - t3, "budget_reeval_s": 2.0,
        "peak_memory_MB_fe_and_sweeps": mem_sweep, "peak_memory_MB": peak_memory_MB(),
        "iso6336_c_gamma_alpha_b_N_per_um": iso * 1e-6,
        "mean_stiffness_N_per_um_120Nm": s["mean_stiffness_N_per_um"],
        "mean_tangent_stiffness_N_per_um_120Nm": s["mean_tangent_stiffness_N_per_um"],
        "ratio_to_iso_c_gamma_alpha": s["mean_stiffness_N_per_um"] * 1e6 / iso,
        "ste_mean_um_120Nm": s["ste_mean_um"], "ste_ptp_um_120Nm": s["ste_ptp_um"],
        "max_contact_pressure_MPa_120Nm": s["max_contact_pressure_MPa"],
        "ste_mean_um_60Nm": res60.summary(0)["ste_mean_um"], "ste_ptp_um_60Nm": res60.summary(0)["ste_ptp_um"],
        "drawing_micro_ste_mean_um": sd["ste_mean_um"], "drawing_micro_ste_ptp_um": sd["ste_ptp_um"],
        "drawing_micro_kinematic_te_ptp_um": sd["kinematic_te_ptp_um"],
        "drawing_micro_max_contact_pressure_MPa": sd["max_contact_pressure_MPa"],
        "lead_crowning_only_ste_mean_um": resc.summary(0)["ste_mean_um"],
        "lead_crowning_only_ste_ptp_um": resc.summary(0)["ste_ptp_um"],
        "tip_relief_only_ste_mean_um": resr.summary(0)["ste_mean_um"],
        "tip_relief_only_ste_ptp_um": resr.summary(0)["ste_ptp_um"],
        "tip_relief_only_max_contact_pressure_MPa": resr.summary(0)["max_contact_pressure_MPa"],
        "crosscheck_3_positions": cross, "crosscheck_and_slices_s": t6 - t5,
        "load_share_pairs": s["load_share_pairs"],
        "max_pair_share": float(np.max(res.load_share[0])),
        "note": ("load average at write in the machine section (above ~1: the 2 cores were shared with other jobs); "
                 "OPENBLAS_NUM_THREADS=1; MKL PARDISO via pypardiso for the 3D factorisations"),
    }
    write_result("bench_stiffness_helical3d", figures)


if __name__ == "__main__":
    main()
