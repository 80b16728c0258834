"""Run-up vs stepped sweep over the whole speed range, at two ramp rates.

Run: ``python benchmarks/bench_study_runup.py``. thesis-spur rig (its GMF amplitudes are ~1 um; the
helical pair's are ~1e-3 um), 250-5000 rpm ramps of 2 s and 8 s, GMF x1-3 compared with settled
constant-speed runs at 24 speeds (both at 64 samples per mesh period). Writes
``results/bench_study_runup.json``: wall time per ramp, the run-up / sweep - 1 differences per speed,
and the speeds of the largest differences (resonance passages).
"""
from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import peak_memory_MB, write_result  # noqa: E402


def main() -> None:
    from gearrom.rom.rig import build_rig
    from gearrom.study.runup import compare_with_sweep, simulate_runup

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = build_rig("thesis-spur")
    rpms = np.linspace(400.0, 4850.0, 24)
    figs: dict = {"config": "thesis-spur (default rig)", "rpm": rpms.tolist(), "samples_per_mesh": 64}
    sweep = None
    for dur in (2.0, 8.0):
        t0 = time.perf_counter()
        res = simulate_runup(model, 250.0, 5000.0, dur)
        wall = time.perf_counter() - t0
        if sweep is None:
            t1 = time.perf_counter()
            cmp = compare_with_sweep(res, model, rpms)
            sweep = (np.array(cmp["sweep_gmf_um"]), time.perf_counter() - t1)
        ru = np.column_stack([res.gmf_at(rpms, m) for m in (1, 2, 3)])
        rel = ru / sweep[0] - 1
        worst = np.argsort(-np.abs(rel[:, 0]))[:3]
        figs[f"ramp_{dur:g}s"] = {
            "ramp_rate_rpm_per_s": res.ramp_rate_rpm_per_s, "wall_s": wall, "n_steps": res.metadata["n_steps"],
            "gmf1_rel_diff": rel[:, 0].tolist(), "gmf2_rel_diff": rel[:, 1].tolist(),
            "gmf1_abs_rel_diff_median": float(np.median(np.abs(rel[:, 0]))),
            "gmf1_largest_abs_rel_diff_at_rpm": [[float(rpms[i]), float(rel[i, 0])] for i in worst]}
        fig = res.plot(compare={"rpm": rpms, "sweep_gmf_um": sweep[0]})
        fig.savefig(Path(__file__).resolve().parent / "results" / f"bench_study_runup_{dur:g}s.png", dpi=100)
    figs["sweep_gmf_um"] = sweep[0].tolist()
    figs["stepped_runs_wall_s"] = sweep[1]
    figs["peak_memory_MB"] = peak_memory_MB()
    write_result("bench_study_runup", figs)


if __name__ == "__main__":
    main()
