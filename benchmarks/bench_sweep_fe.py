"""Benchmark: the main job on quasi-static FE tables with the load-dependent mesh law (thesis-rig).

Figures, measured in one run:

* the README's main job (sweep 250-5000 rpm step 250 + Campbell) on ``[rom] excitation = "fe"``
  from a cold cache (a fresh, empty ``GEARROM_CACHE_DIR``: 3D FE compliances, the FE table over the
  torque map) and again warm;
* the 191-speed sweep (250-5000 rpm step 25, 2 output revolutions per speed, 2 processes) on the FE
  tables with the load-dependent law and with the secant law (``rom.mesh_law = "secant"``), and
  their ratio;
* one speed (1250 rpm): microseconds per step, and again with the Python pre-step function that
  sets the mesh law per step replaced by one that does nothing (exudyn's integration alone); the
  difference is the share of the per-step mesh update.

Run: python benchmarks/bench_sweep_fe.py [--quick] [--sweeps-only]
(--quick: 250:5000:250 instead of step 25; --sweeps-only: skip the main-job timings and use the
user's cache, for a look at the sweep alone; the result file is not written)
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import peak_memory_MB, write_result  # noqa: E402

CONFIG = 'extends = "thesis-rig"\nname = "thesis-rig-fe"\n[rom]\nexcitation = "fe"\nmesh_law = "{law}"\n'


def _main_job(cfg: Path, out: Path, env: dict) -> float:
    t0 = time.perf_counter()
    for argv in (["sweep", str(cfg), "--rpm", "250:5000:250", "--out", str(out / "sweep"), "--no-progress"],
                 ["campbell", str(cfg), "--json", str(out / "campbell.json"), "--plot", str(out / "campbell.png")]):
        subprocess.run([sys.executable, "-c", "import sys; from gearrom.cli import main; sys.exit(main(sys.argv[1:]))",
                        *argv], check=True, env=env, capture_output=True)
    return time.perf_counter() - t0


def main() -> None:
    warnings.simplefilter("ignore")
    rpm = "250:5000:250" if "--quick" in sys.argv[1:] else "250:5000:25"
    from gearrom.rom.meshstep import MeshStepper
    from gearrom.rom.rig import build_rig
    from gearrom.rom.simulate import simulate_run
    from gearrom.rom.sweep import parse_rpm, run_sweep

    figures: dict = {"rpm": rpm}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cfgs = {}
        for law in ("load-dependent", "secant"):
            cfgs[law] = tmp / f"rig-fe-{law}.toml"
            cfgs[law].write_text(CONFIG.format(law=law))
        sweeps_only = "--sweeps-only" in sys.argv[1:]
        if not sweeps_only:
            env = {**os.environ, "GEARROM_CACHE_DIR": str(tmp / "cache"), "MPLBACKEND": "Agg"}
            figures["main_job_cold_cache_wall_s"] = round(_main_job(cfgs["load-dependent"], tmp / "cold", env), 2)
            figures["main_job_warm_cache_wall_s"] = round(_main_job(cfgs["load-dependent"], tmp / "warm", env), 2)
            os.environ["GEARROM_CACHE_DIR"] = env["GEARROM_CACHE_DIR"]
        for law, cfg in cfgs.items():
            t0 = time.perf_counter()
            res = run_sweep(str(cfg), parse_rpm(rpm), tmp / f"sweep-{law}", processes=2, n_output_revs=2.0,
                            progress=False, linear=False)
            wall = time.perf_counter() - t0
            sim = float(sum(s["simulated_s"] for s in res.summary))
            figures[law] = {"sweep_wall_s": round(wall, 2), "speeds": len(res.rpm),
                            "simulated_s_per_wall_s": round(sim / wall, 3),
                            "excitation": res.metadata["excitation"]["source"]}
            model = build_rig(cfg)
            simulate_run(model, 1250.0, n_output_revs=2)  # warm-up
            t0 = time.perf_counter()
            run = simulate_run(model, 1250.0, n_output_revs=2)
            one = time.perf_counter() - t0
            us = run.metadata["wall_s"] / run.metadata["n_steps"] * 1e6
            # the same run with the per-step mesh update replaced by a pre-step that does nothing (its
            # result is wrong; only the time counts): what exudyn's integration alone costs per step
            real = MeshStepper.pre_step
            MeshStepper.pre_step = lambda self, mbs, t: True
            try:
                bare = simulate_run(model, 1250.0, n_output_revs=2)
            finally:
                MeshStepper.pre_step = real
            us_bare = bare.metadata["wall_s"] / bare.metadata["n_steps"] * 1e6
            figures[law].update(one_speed_1250rpm_wall_s=round(one, 3), steps=run.metadata["n_steps"],
                                us_per_step=round(us, 2), us_per_step_empty_pre_step=round(us_bare, 2),
                                mesh_update_share_of_solve=round(1 - us_bare / us, 3))
        figures["load_dependent_over_secant_sweep_wall"] = round(
            figures["load-dependent"]["sweep_wall_s"] / figures["secant"]["sweep_wall_s"], 3)
    figures["peak_memory_MB"] = round(peak_memory_MB(), 1)
    figures["note"] = ("2 cores; the load average at write time says how far other jobs shared them; the cold "
                       "main job includes the 3D FE compliances of both gears and the FE table")
    for k, v in figures.items():
        print(f"{k}: {v}")
    if "--sweeps-only" not in sys.argv[1:]:
        write_result("bench_sweep_fe" + ("_quick" if rpm.endswith(":250") else ""), figures)


if __name__ == "__main__":
    main()
