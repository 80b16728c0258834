"""Wall time of one diagnosis (2 runs x 6 output revolutions, 1250 and 2000 rpm, helical thesis-rig pair or
the spur pair on the same rig) on the independent simulator's records, budget 60 s on 2 cores.

Cases: the slowest kinds of the acceptance matrix (``bench_diagnose_independent.py``): records where
nothing is found (clean; flank modifications and a re-tuned clutch below what the TE shows), so that
every candidate is fitted, the flank-modification candidates re-simulated and the rig parameters
searched; and records where effects are found (a proud tooth, runout + proud tooth, runout + encoder
eccentricity on one shaft).

* warm: the quasi-static FE tables of the micro-geometry variants the fits ask for are in the FE cache
  (a second diagnosis of the same pair; the first one computes them);
* cold: ``--cold`` runs each case once more with an empty micro-geometry cache (the nominal FE tables
  of the pair, which the main job computes, present).

Each diagnosis runs in a fresh process, as ``gearrom diagnose`` does (tables read from the FE cache on
disk). The machine's load average is recorded before each: run it on an otherwise idle machine.

Usage::

    python benchmarks/bench_diagnose_speed.py [--pair helical|spur] [--cold] [--only TEXT]

``--only`` updates those cases in the stored result and keeps the others. Results:
``bench_diagnose_speed.json`` (helical), ``bench_diagnose_speed_spur.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # datasim, under the name the tests use
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import RESULTS, write_result  # noqa: E402
from bench_diagnose_independent import CACHE, RPMS, cases, spur_rig_config  # noqa: E402
from datasim import make_case_files  # noqa: E402

CASES = {"helical": ("clean", "tip_output_2x", "tip_output_4x", "crown_1x", "slope_4x", "clutch_0.5",
                     "pitch_input_1x", "ecc_in+pitch_out", "enc_out+ecc_out"),
         # the spur matrix's slowest kinds: a proud tooth found with a rig change, effects found, nothing found
         "spur": ("clean", "pitch_input_4x", "pitch_output_4x", "ecc_in+pitch_out", "slope_4x", "clutch_0.5")}
BUDGET_S = 60.0


def _time_case(cid: str, pair: str, cache_dir: Path | None = None) -> dict:
    """One diagnosis of case ``cid`` in a fresh process (as ``gearrom diagnose`` runs): wall and CPU time [s]."""
    env = dict(os.environ)
    if cache_dir is not None:
        env["GEARROM_CACHE_DIR"] = str(cache_dir)
    load = os.getloadavg()[0]
    r = subprocess.run([sys.executable, __file__, "--one", cid, "--pair", pair], env=env, capture_output=True, text=True, check=True)
    return {**json.loads(r.stdout.strip().splitlines()[-1]), "load_average_1min_before": load}


def _one(cid: str, pair: str) -> None:
    from gearrom.calibrate import diagnose

    (case,) = [c for i, c, _ in cases(pair, (0.5, 1, 2, 4)) if i == cid]
    files = make_case_files(CACHE, case, rpms=RPMS, pair=pair)
    config = "thesis-rig" if pair == "helical" else str(spur_rig_config(CACHE))
    t0, c0 = time.perf_counter(), time.process_time()
    res = diagnose(config, files)
    sys.stdout.write(json.dumps({"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
                                 "effects_found": len(res.summary["effects"])}) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pair", choices=("helical", "spur"), default="helical")
    ap.add_argument("--cold", action="store_true", help="also time each case with an empty micro-geometry cache")
    ap.add_argument("--only", help="run the cases whose id contains this text")
    ap.add_argument("--one", help=argparse.SUPPRESS)  # internal: one timed diagnosis in this process
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    warnings.simplefilter("ignore")
    if args.one:
        _one(args.one, args.pair)
        return 0
    name = "bench_diagnose_speed" + ("" if args.pair == "helical" else f"_{args.pair}")
    out = {"budget_s": BUDGET_S, "rpms": list(RPMS), "pair": args.pair, "cases": {}}
    stored = RESULTS / f"{name}.json"
    if args.only and stored.exists():  # a partial run updates its cases in the stored result
        out["cases"] = json.loads(stored.read_text())["figures"]["cases"]
    for cid in (c for c in CASES[args.pair] if not args.only or args.only in c):
        _time_case(cid, args.pair)  # fills the FE cache with the micro-geometry tables this case asks for
        entry = {"warm": _time_case(cid, args.pair)}
        if args.cold:
            from gearrom.fe.sweep import default_cache_dir

            tmp = Path(tempfile.mkdtemp(prefix="gearrom-cold-"))
            try:  # the nominal FE tables and compliances only, as after the main job
                shutil.copytree(default_cache_dir(), tmp / "fe")
                entry["cold"] = _time_case(cid, args.pair, tmp)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        out["cases"][cid] = entry
        logging.getLogger("bench").warning("%s: %s", cid, entry)
    walls = [c["warm"]["wall_s"] for c in out["cases"].values()]
    out["warm_wall_s_max"] = max(walls) if walls else None
    out["within_budget_warm"] = bool(walls) and max(walls) < BUDGET_S
    colds = [c["cold"]["wall_s"] for c in out["cases"].values() if "cold" in c]
    if colds:
        out["cold_wall_s_max"] = max(colds)
        out["within_budget_cold"] = max(colds) < BUDGET_S
    write_result(name, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
