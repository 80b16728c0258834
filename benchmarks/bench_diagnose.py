"""Benchmark of ``gearrom diagnose``: wall time for 2 runs of 2 output revolutions (target <= 60 s on
2 cores), plus a matrix of undeclared-effect cases at two speeds (issue 6 acceptance, heavier than the suite).

Run: ``python benchmarks/bench_diagnose.py [--quick]``. Writes ``benchmarks/results/bench_diagnose.json``.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py (script, not a test)
from _common import peak_memory_MB, write_result  # noqa: E402

from gearrom.calibrate import Injected, MicroMods, RomSimulator, TorsionalRig, diagnose, make_run  # noqa: E402

CASES = {
    "eccentricity/output_gear": (Injected(eccentricity={"output_gear": (10.0, 40.0)}), ("eccentricity", "output_gear"),
                                 {"amplitude_um": 10.0, "phase_deg": 40.0}, "thesis-helical"),
    "eccentricity/input_gear": (Injected(eccentricity={"input_gear": (8.0, -120.0)}), ("eccentricity", "input_gear"),
                                {"amplitude_um": 8.0, "phase_deg": -120.0}, "thesis-helical"),
    "encoder_eccentricity/input_encoder": (Injected(encoder={"input_encoder": (12.0, -70.0)}),
                                           ("encoder_eccentricity", "input_encoder"),
                                           {"amplitude_um": 12.0, "phase_deg": -70.0}, "thesis-helical"),
    "pitch_error/output_gear": (Injected(pitch={"output_gear": (30, 6.0)}), ("pitch_error", "output_gear"),
                                {"deviation_um": 6.0, "tooth_index": 30}, "thesis-helical"),
    "tip_relief/output_gear": (Injected(micro=MicroMods(tip_relief=(0.0, 15e-6),
                                                        tip_relief_start_diameter=(59.37e-3, 74.29e-3))),
                               ("tip_relief", "output_gear"), {"amount_um": 15.0}, "thesis-helical"),
    "lead_crowning": (Injected(micro=MicroMods(lead_crowning=7e-6)), ("lead_crowning", None), {"amount_um": 7.0},
                      "thesis-helical"),
    "helix_slope": (Injected(micro=MicroMods(helix_slope=11e-6)), ("helix_slope", None), {"amount_um": 11.0},
                    "thesis-helical"),
    "torsional_mode (k_clutch x1.5, spur)": (Injected(rig_scale=(("k_clutch", 1.5),)), ("torsional_mode", None),
                                             {"scale": 1.5}, "thesis-spur"),
    "runout in + encoder out": (Injected(eccentricity={"input_gear": (10.0, 120.0)},
                                         encoder={"output_encoder": (8.0, -30.0)}),
                                ("eccentricity", "input_gear"), {"amplitude_um": 10.0, "phase_deg": 120.0},
                                "thesis-helical"),
    "negative control": (Injected(), (None, None), {}, "thesis-helical"),
    "load ripple at output order 3.4": (Injected(load_ripple=(0.05, 3.4, 0.5)), (None, None), {}, "thesis-helical"),
}


def timed_case(tmp: Path, rigs: dict) -> dict:
    """The timing case: 2 runs (1250 and 2500 rpm) of 2 output revolutions, two effects at once."""
    rig = rigs.setdefault("thesis-helical", TorsionalRig.from_config("thesis-helical"))
    inj = CASES["runout in + encoder out"][0]
    t0 = time.perf_counter()
    paths = [make_run(tmp / f"t{int(r)}.json", "thesis-helical", r, simulator=rig, injected=inj, seed=int(r))
             for r in (1250.0, 2500.0)]
    t1 = time.perf_counter()
    res = diagnose("thesis-helical", paths, simulator=rig)
    t2 = time.perf_counter()
    return {"generate_s": t1 - t0, "diagnose_s": t2 - t1, "effects": [(e["effect"], e["target"]) for e in res.effects],
            "error_before_rms_um": res.summary["error_before_rms_um"],
            "error_after_rms_um": res.summary["error_after_rms_um"]}


def timed_rom(tmp: Path) -> dict:
    """The same timing case with the exudyn ROM as the model (and as the data generator)."""
    rom = RomSimulator("thesis-helical")
    inj = CASES["runout in + encoder out"][0]
    paths = [make_run(tmp / f"rom{int(r)}.json", "thesis-helical", r, simulator=rom, injected=inj, seed=int(r))
             for r in (1250.0, 2500.0)]
    t = time.perf_counter()
    res = diagnose("thesis-helical", paths, simulator=rom)
    return {"diagnose_s": time.perf_counter() - t, "effects": [(e["effect"], e["target"]) for e in res.effects],
            "error_before_rms_um": res.summary["error_before_rms_um"],
            "error_after_rms_um": res.summary["error_after_rms_um"]}


def matrix(tmp: Path, rigs: dict, speeds=(1250.0, 2500.0)) -> dict:
    out = {}
    for name, (inj, (eff, tgt), truth, cfg) in CASES.items():
        rig = rigs.setdefault(cfg, TorsionalRig.from_config(cfg))
        d = tmp / name.replace("/", "_").replace(" ", "_")
        d.mkdir()
        sp = (1250.0, 2000.0) if "ripple" in name else speeds
        revs = 4.0 if "ripple" in name else 2.0
        paths = [make_run(d / f"r{int(r)}.json", cfg, r, simulator=rig, injected=inj, seed=int(r), revs_out=revs)
                 for r in sp]
        t = time.perf_counter()
        res = diagnose(cfg, paths, simulator=rig)
        row = {"seconds": time.perf_counter() - t, "found": [(e["effect"], e["target"]) for e in res.effects],
               "error_before_rms_um": res.summary["error_before_rms_um"],
               "error_after_rms_um": res.summary["error_after_rms_um"],
               "unexplained": [(round(u["frequency_hz"], 1), u["kind"], u["order_out"]) for u in res.unexplained][:4],
               "ambiguities": [(a["chosen"], a["alternative"]) for a in res.summary["ambiguities"]]}
        if eff is not None:
            e = res.effects[0] if res.effects else None
            row["named_first"] = bool(e and (e["effect"], e["target"]) == (eff, tgt))
            if e:
                row["fitted"] = {k: e["parameters"].get(k) for k in truth}
                row["truth"] = truth
            row["after_le_half_before"] = res.summary["error_after_rms_um"] <= 0.5 * res.summary["error_before_rms_um"]
        else:
            row["no_effect_added"] = not res.effects
        out[name] = row
        sys.stdout.write(f"{name}: {row}\n")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="timing case only")
    args = ap.parse_args(argv)
    rigs: dict = {}
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        t1 = timed_case(tmp, rigs)
        t2 = timed_case(tmp, rigs)  # second call: numba caches and imports warm
        t3 = timed_rom(tmp)
        figures = {"diagnose_2runs_2revs_s_first": t1["diagnose_s"], "diagnose_2runs_2revs_s": t2["diagnose_s"],
                   "diagnose_2runs_2revs_rom_s": t3["diagnose_s"], "target_s": 60.0, "timing_case": t2,
                   "timing_case_rom": t3, "load_average_1min": os.getloadavg()[0],
                   "note": "2 cores shared with other helpers' jobs while measuring (load average above). Timing "
                           "case: runout of the input gear + output encoder eccentricity, 1250 and 2500 rpm, 2 output "
                           "revolutions each; model = torsional rig (default for configs without [rig]); "
                           "'_first' includes imports and numba compilation; '_rom_s' uses the exudyn ROM."}
        if not args.quick:
            figures["matrix"] = matrix(tmp, rigs)
        else:
            old = Path(__file__).resolve().parent / "results" / "bench_diagnose.json"
            if old.exists():
                import json

                prev = json.loads(old.read_text())
                if "matrix" in prev.get("figures", {}):
                    figures["matrix"] = prev["figures"]["matrix"]
                    figures["matrix_measured_utc"] = prev["machine"]["date_utc"]
        figures["peak_memory_MB"] = peak_memory_MB()
    write_result("bench_diagnose", figures)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
