"""Benchmark: mesh refinement study of the spur pair FE LTCA (mean stiffness and STE peak-to-peak).

All mesh sizes (flank, tooth, body; the flank grid follows the flank size) are scaled by
h/h_default in 2^(k/2) steps (r = sqrt 2), from 2x the default down to 0.5x. The observed order p
comes from the three finest meshes, p = ln((f1 - f2)/(f2 - f3)) / ln(r), and the Richardson
extrapolation (L. F. Richardson, Phil. Trans. R. Soc. A 210 (1911) 307-357; the grid-convergence
procedure of P. J. Roache, J. Fluids Eng. 116 (1994) 405-413) f* = f3 + (f3 - f2)/(r^p - 1).
The acceptance: the default mesh (factor 1) lies within 2 % of f*.

The unmodified teeth touch early/late with their tip edges. The FE rounds the tip edges
(gearrom.fe.tipedge: the config's tip_edge_radius_mm, default 0.1 m_n = 0.15 mm); with sharp
corners the edge contact was singular (peak pressure 1.7 -> 4.1 GPa over this ladder, STE
peak-to-peak 2.55 -> 1.68 um, default 15 % off; results of 2026-11-22T01:16 in git history).
The same study with a long tip relief (no edge contact) is reported next to it ("relief_*").

Run: python benchmarks/bench_stiffness_refinement.py   (--reanalyse: figures from the stored rows)
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path

from _common import peak_memory_MB, write_result

from gearrom.config import load_config
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.ltca import SpurLTCA
from gearrom.fe.sweep import build_ltca, mesh_cycle

FACTORS = (2.0, math.sqrt(2.0), 1.0, 1 / math.sqrt(2.0), 0.5)


def richardson(f: list[float], r: float) -> tuple[float, float]:
    """Observed order and Richardson extrapolation from the three finest values (nan order: oscillatory)."""
    f1, f2, f3 = f[-3:]
    ratio = (f1 - f2) / (f2 - f3) if f2 != f3 else float("inf")
    if not 0 < ratio < float("inf"):
        return float("nan"), f3  # oscillatory convergence: no order, take the finest
    p = math.log(ratio) / math.log(r)
    return p, f3 + (f3 - f2) / (r**p - 1)


def analyse(vals: list[float], r: float, i_def: int) -> dict:
    """Convergence figures of one quantity. Richardson needs a monotone asymptotic range (order 0.5..6);
    otherwise the finest value is the estimate and the spread of the three finest its uncertainty."""
    p, fx = richardson(vals, r)
    asymptotic = bool(0.5 <= p <= 6.0)
    if not asymptotic:
        fx = vals[-1]
    spread = 100 * (max(vals[-3:]) - min(vals[-3:])) / abs(vals[-1])
    return {"observed_order": p, "asymptotic": asymptotic, "extrapolated": fx, "default": vals[i_def],
            "default_deviation_percent": 100 * (vals[i_def] - fx) / fx,
            "finest_deviation_percent": 100 * (vals[-1] - fx) / fx,
            "spread_three_finest_percent": spread,
            "observed_order_per_triple": [richardson(vals[:k + 1], r)[0] for k in range(2, len(vals))],
            "change_per_level_percent": [100 * (b - a) / a for a, b in zip(vals, vals[1:])]}


def relieved(pair, amount: float = 10e-6):
    """Long linear tip relief on both gears from the end of single contact (no sharp-corner contact)."""
    gears = []
    for i, g in enumerate(pair.gears):
        d_ca = 2 * math.hypot(pair.rb[i], pair.roll_tip[i] - pair.pb_t)
        gears.append(dataclasses.replace(g, micro=dataclasses.replace(g.micro, enabled=True, tip_relief=amount,
                                                                       tip_relief_start_diameter=d_ca)))
    return dataclasses.replace(pair, gears=tuple(gears))


def main() -> None:
    if "--reanalyse" in sys.argv:  # recompute the figures from the stored rows (no FE run)
        stored = json.loads((Path(__file__).parent / "results" / "bench_stiffness_refinement.json").read_text())
        return summarise(stored["figures"]["rows"], stored["figures"].get("peak_memory_MB", float("nan")))
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
                     "relief_max_contact_pressure_MPa": rel["max_contact_pressure_MPa"],
                     "early_pair_share_max": float(res.load_share[0][..., res.pairs < 0].max()) if (res.pairs < 0).any() else 0.0,
                     "ste_um": [round(v, 5) for v in sm["ste_um"]]})
        print({k: v for k, v in rows[-1].items() if k != "ste_um"}, flush=True)
    summarise(rows, peak_memory_MB())


def summarise(rows: list[dict], memory_MB: float) -> None:
    r = math.sqrt(2.0)
    figures = {"rows": rows}
    i_def = FACTORS.index(1.0)
    for key in ("mean_stiffness_N_per_um", "ste_ptp_um", "ste_mean_um", "relief_ste_ptp_um",
                "relief_mean_stiffness_N_per_um", "max_contact_pressure_MPa", "relief_max_contact_pressure_MPa"):
        figures[key] = analyse([row[key] for row in rows], r, i_def)
    figures["peak_memory_MB"] = memory_MB
    figures["summary"] = (
        "unmodified teeth, rounded tip edges: mean stiffness converges monotonically (observed order "
        f"{figures['mean_stiffness_N_per_um']['observed_order']:.2f} on the three finest meshes), default "
        f"{figures['mean_stiffness_N_per_um']['default_deviation_percent']:+.2f} % from the Richardson value; STE "
        f"peak-to-peak stays within a {figures['ste_ptp_um']['spread_three_finest_percent']:.2f} % band over the "
        "three finest meshes (changes of 0.1-0.25 % per level without a consistent ratio: no asymptotic order is "
        "resolvable at that level), default "
        f"{figures['ste_ptp_um']['default_deviation_percent']:+.2f} % from the finest; the peak pressure (on the "
        "tip edge rounding) saturates once the flank grid resolves the Hertz width of the 0.15 mm rounding")
    figures["note"] = ("2 cores shared with other helpers' jobs; sizes scaled together (flank, tooth, body, grid); "
                       "tip edges rounded with 0.15 mm (default 0.1 m_n, no radius in the config); 64 positions, 120 N m")
    write_result("bench_stiffness_refinement", figures)


if __name__ == "__main__":
    main()
