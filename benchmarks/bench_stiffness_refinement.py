"""Benchmark: mesh refinement study of the spur pair FE LTCA (mean stiffness and STE peak-to-peak).

All mesh sizes (flank, tooth, body; the flank grid follows the flank size) are scaled by
h/h_default in 2^(k/2) steps. The observed order p comes from the three finest meshes,
p = ln((f1 - f2)/(f2 - f3)) / ln(r), and the Richardson extrapolation f* = f3 + (f3 - f2)/(r^p - 1).
The acceptance: the default mesh (factor 1) lies within 2 % of f*. The unmodified teeth have sharp
tip corners, whose edge contact is singular (pressure grows without bound with refinement), so
their STE peak-to-peak converges slowly; the same study with a long tip relief (no corner contact)
is reported next to it ("relief_*").

Run: python benchmarks/bench_stiffness_refinement.py
"""
from __future__ import annotations

import dataclasses
import math
import time

from _common import peak_memory_MB, write_result

from gearrom.config import load_config
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.ltca import SpurLTCA
from gearrom.fe.sweep import build_ltca, mesh_cycle

FACTORS = (2.0, math.sqrt(2.0), 1.0, 1 / math.sqrt(2.0))


def richardson(f: list[float], r: float) -> tuple[float, float]:
    f1, f2, f3 = f[-3:]
    ratio = (f1 - f2) / (f2 - f3)
    if ratio <= 0:
        return float("nan"), f3  # oscillatory convergence: no order, take the finest
    p = math.log(ratio) / math.log(r)
    return p, f3 + (f3 - f2) / (r**p - 1)


def relieved(pair, amount: float = 10e-6):
    """Long linear tip relief on both gears from the end of single contact (no sharp-corner contact)."""
    gears = []
    for i, g in enumerate(pair.gears):
        d_ca = 2 * math.hypot(pair.rb[i], pair.roll_tip[i] - pair.pb_t)
        gears.append(dataclasses.replace(g, micro=dataclasses.replace(g.micro, enabled=True, tip_relief=amount,
                                                                       tip_relief_start_diameter=d_ca)))
    return dataclasses.replace(pair, gears=tuple(gears))


def main() -> None:
    pair = load_config("thesis-spur").pair
    rows = []
    for fac in FACTORS:
        s = MeshSettings().scaled(fac)
        t0 = time.perf_counter()
        ltca = build_ltca(pair, s, cache_dir=None)
        res = mesh_cycle(ltca, [120.0], 64)
        rel = mesh_cycle(SpurLTCA(relieved(pair), ltca.c), [120.0], 64).summary(0)
        sm = res.summary(0)
        rows.append({"factor": fac, "flank_size_mm": s.flank_size * 1e3, "dofs": [c["dofs"] for c in res.metadata["compliance_info"]],
                     "time_s": time.perf_counter() - t0, "mean_stiffness_N_per_um": sm["mean_stiffness_N_per_um"],
                     "ste_ptp_um": sm["ste_ptp_um"], "ste_mean_um": sm["ste_mean_um"],
                     "max_contact_pressure_MPa": sm["max_contact_pressure_MPa"],
                     "relief_ste_ptp_um": rel["ste_ptp_um"], "relief_mean_stiffness_N_per_um": rel["mean_stiffness_N_per_um"],
                     "relief_max_contact_pressure_MPa": rel["max_contact_pressure_MPa"]})
        print(rows[-1], flush=True)
    r = math.sqrt(2.0)
    figures = {"rows": rows}
    i_def = FACTORS.index(1.0)
    for key in ("mean_stiffness_N_per_um", "ste_ptp_um", "ste_mean_um", "relief_ste_ptp_um",
                "relief_mean_stiffness_N_per_um", "max_contact_pressure_MPa", "relief_max_contact_pressure_MPa"):
        vals = [row[key] for row in rows]
        p, fx = richardson(vals, r)
        figures[key] = {"observed_order": p, "extrapolated": fx, "default": vals[i_def],
                        "default_deviation_percent": 100 * (vals[i_def] - fx) / fx}
    figures["peak_memory_MB"] = peak_memory_MB()
    figures["note"] = "2 cores shared with other helpers' jobs; sizes scaled together (flank, tooth, body, grid)"
    write_result("bench_stiffness_refinement", figures)


if __name__ == "__main__":
    main()
