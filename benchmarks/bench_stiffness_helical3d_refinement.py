"""Benchmark: refinement study of the 3D helical model (thesis-helical, 120 N m, 32 positions).

Mesh levels: all lengths of the reference mesh (flank 0.45, tooth 0.8, body 3.0 mm, 0.9 mm layers,
7-tooth elastic sector) scaled by 1.6, 1.25 and 1.0 (the finest that fits the shared machine), plus
variations at level 1.6 (the default mesh): 5-tooth sector, read-out depth 1.0 mm instead of 0.6 mm (Vijayakar split:
must not matter), finer LTCA (36 strips, 0.015 mm patches across the line). Figures per level: dofs,
mean secant stiffness, mean STE, STE p-p, ratio to ISO 6336 c_gamma_alpha, FE time; the observed
differences to the finest level (the default mesh is chosen as the cheapest level within 2 %).

Run: python benchmarks/bench_stiffness_helical3d_refinement.py
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small dense contact problems: threads only stall

import dataclasses  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

from _common import peak_memory_MB, write_result  # noqa: E402

from gearrom.config import load_config  # noqa: E402
from gearrom.fe.compliance3d import cached_compliance3d  # noqa: E402
from gearrom.fe.ltca_helical import Helical3DLTCA  # noqa: E402
from gearrom.fe.iso6336 import mesh_stiffness  # noqa: E402
from gearrom.fe.mesh3d import Mesh3DSettings  # noqa: E402
from gearrom.fe.sweep import mesh_cycle  # noqa: E402

REF = Mesh3DSettings(flank_size=0.45e-3, tooth_size=0.8e-3, body_size=3.0e-3, layer=0.9e-3, teeth=3)


def run(pair, settings, cache, depth=0.6e-3, **ltca_kw) -> dict:
    t0 = time.perf_counter()
    comps = tuple(cached_compliance3d(pair, i, settings, cache_dir=cache, depth=depth) for i in range(2))
    t1 = time.perf_counter()
    res = mesh_cycle(Helical3DLTCA(pair, comps, **ltca_kw), [120.0], 32, tangent=False)
    s = res.summary(0)
    return {"dofs": [c.info["dofs"] for c in comps], "fe_s": t1 - t0, "solver": comps[0].info["solver"],
            "mean_stiffness_N_per_um": s["mean_stiffness_N_per_um"], "ste_mean_um": s["ste_mean_um"],
            "ste_ptp_um": s["ste_ptp_um"], "max_contact_pressure_MPa": s["max_contact_pressure_MPa"],
            "ratio_iso": s["mean_stiffness_N_per_um"] * 1e6 / (mesh_stiffness(pair) * pair.face_width)}


def main() -> None:
    warnings.simplefilter("ignore")
    pair = load_config("thesis-helical").pair
    levels = {}
    with tempfile.TemporaryDirectory() as cache:
        for f in (1.6, 1.25, 1.0):  # 1.6 is the default mesh
            levels[f"scale_{f}"] = run(pair, REF.scaled(f), cache)
            print(f, levels[f"scale_{f}"], flush=True)
        mid = REF.scaled(1.6)
        levels["scale_1.6_5teeth"] = run(pair, dataclasses.replace(mid, teeth=2), cache)
        levels["scale_1.6_depth1mm"] = run(pair, mid, cache, depth=1.0e-3)
        levels["scale_1.6_fine_ltca"] = run(pair, mid, cache, n_slices=36, d_mu=0.015e-3)
    fine = levels["scale_1.0"]
    for v in levels.values():
        v["dk_vs_finest_pct"] = 100 * (v["mean_stiffness_N_per_um"] / fine["mean_stiffness_N_per_um"] - 1)
        v["dste_mean_vs_finest_pct"] = 100 * (v["ste_mean_um"] / fine["ste_mean_um"] - 1)
        v["dste_ptp_vs_finest_um"] = v["ste_ptp_um"] - fine["ste_ptp_um"]
    figures = {"reference_mesh": dataclasses.asdict(REF), "levels": levels, "peak_memory_MB": peak_memory_MB(),
               "note": "2 cores shared with other helpers' jobs while this ran; levels scale every mesh length"}
    write_result("bench_stiffness_helical3d_refinement", figures)


if __name__ == "__main__":
    main()
