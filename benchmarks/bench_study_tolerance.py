"""Tolerance study throughput: samples x 96 speeds on an embedded LocalCluster, 1 and 2 worker processes.

Run: ``python benchmarks/bench_study_tolerance.py [N_SAMPLES] [N_SCALING]`` (defaults 200 and 8).
thesis-rig, ISO 1328-1 grade 6 pitch/runout/helix slope plus the drawing's tip relief and crowning
tolerances, flank modifications through the FE contact with cached compliances (no FE solve), 96
speeds 250-5000 rpm, 1 output revolution per speed. Writes ``results/bench_study_tolerance.json``:
samples/s, the scaling from 1 to 2 workers (on N_SCALING samples), the per-task CPU cost, the
scheduler overhead per task (wall of no-op tasks), and an estimate of the wall time of 10,000 samples
on 100 cores: ``ceil(10000 / 100) * t_task + 10000 * t_sched`` with the measured per-task wall on one
worker and the measured scheduler overhead per task.
"""
from __future__ import annotations

import math
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import peak_memory_MB, write_result  # noqa: E402

UM = 1e-6


def _noop(x):
    return x


def main() -> None:
    from distributed import Client, LocalCluster

    from gearrom.config import load_config
    from gearrom.study.distributed import run_tasks
    from gearrom.study.scatter import StudySettings, run_tolerance_study
    from gearrom.study.tolerance import ToleranceSpec

    n_full = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    n_scal = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config("thesis-rig")
    spec = ToleranceSpec.from_grade(cfg.pair, 6, tip_relief=((8 * UM, 4 * UM), (15 * UM, 5 * UM)),
                                    lead_crowning=(4 * UM, 3 * UM))
    rpm = tuple(np.linspace(250.0, 5000.0, 96))
    st = StudySettings(rpm, cfg.operating.torque_out, 1.0, 32, "fe")
    figs: dict = {"config": "thesis-rig", "speeds": len(rpm), "rpm_range": [250, 5000], "n_output_revs": 1.0,
                  "micro_model": "fe", "tolerances": spec.source + " + drawing C_a 8+-4 / 15+-5 um, C_b 4+-3 um"}
    scaling = {}
    for nw in (1, 2):
        with tempfile.TemporaryDirectory() as tmp, LocalCluster(n_workers=nw, threads_per_worker=1,
                                                                dashboard_address=None) as cl, Client(cl) as client:
            client.submit(_noop, 0).result()  # workers up
            t0 = time.perf_counter()
            res = run_tolerance_study("thesis-rig", spec, n_scal, st, tmp, seed=1, client=client, progress=False)
            wall = time.perf_counter() - t0
            scaling[nw] = {"samples": n_scal, "wall_s": wall, "samples_per_s": n_scal / wall,
                           "cpu_s_per_sample_mean": float(np.mean(res.cpu_s))}
            if nw == 1:
                t0 = time.perf_counter()
                run_tasks(_noop, list(range(1000)), client, progress=False, desc="noop")
                figs["scheduler_overhead_s_per_task"] = (time.perf_counter() - t0) / 1000
    figs["scaling"] = scaling
    figs["speedup_2_vs_1_worker"] = scaling[2]["samples_per_s"] / scaling[1]["samples_per_s"]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_tolerance_study("thesis-rig", spec, n_full, st, tmp, seed=0, n_workers=2, progress=False)
        wall = time.perf_counter() - t0
        res.save(Path(tmp) / "study.nc")
    figs["full"] = {"samples": n_full, "workers": 2, "wall_s": wall, "samples_per_s": n_full / wall,
                    "speed_runs_per_s": n_full * len(rpm) / wall, "cpu_s_per_sample_mean": float(np.mean(res.cpu_s)),
                    "cpu_s_per_sample_p95": float(np.percentile(res.cpu_s, 95)),
                    "sensitivity_gmf1_top3": res.sensitivity("gmf1")[:3],
                    "gmf1_um_p5_p50_p95_at_max_p50": None}
    p = res.percentiles()["gmf_um"][..., 0]
    j = int(np.argmax(p[1]))
    figs["full"]["gmf1_um_p5_p50_p95_at_max_p50"] = {"rpm": float(rpm[j]), "values": p[:, j].tolist()}
    t_task = scaling[1]["wall_s"] / n_scal
    t_sched = figs["scheduler_overhead_s_per_task"]
    figs["estimate_10000_samples_100_cores_s"] = math.ceil(10000 / 100) * t_task + 10000 * t_sched
    figs["estimate_basis"] = ("ceil(10000/100) tasks per core x measured wall per task on 1 worker + 10000 x measured "
                              "scheduler overhead per task (no-op round trip, serial at the client); ignores the "
                              "first FE-cache load per worker and data transfer (each task returns < 100 kB)")
    figs["peak_memory_MB_client"] = peak_memory_MB()
    write_result("bench_study_tolerance", figs)


if __name__ == "__main__":
    main()
