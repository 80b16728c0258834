"""Benchmark of the sampled-quadrature reader (kind ``quadrature``): decoding + checks + TE.

A record of two 1000-line encoders on a 15/30 pair (the small test stage of
``tests/signal/quad_synth.py``), sampled at 2 MHz for ``--seconds`` with logic-level (int16)
A/B samples in an HDF5 file, the input at 5830 rpm: x4 edge rate 388.7 kHz on the input, about
5.15 samples per edge interval (10.3 on the output). The rate is not a whole multiple of the
edge rate, so the sampling error of the edge times does not repeat with the angle (it would
then show as a false shaft order). The file is processed by ``process_measurement`` in a fresh
child process that reports its wall time (after ``import gearrom.signal``, timed separately:
``import_s``) and peak resident memory; the decoder alone (file to
signed edges of both encoders, ``gearrom.signal.qload.decode``) runs in another fresh child.
Figures: edges/s and peak memory of the decoder and of the whole processing (targets >= 5 M
edges/s and memory bounded by the chunk size plus the decoded edges), samples/s, and the TE
accuracy against the emulated truth (rms of the difference after
the angle detrend and the unknown angle at the first edge are taken out; GMF amplitude).

Usage::

    python benchmarks/bench_signal_quadrature.py [--seconds 10] [--dir /tmp/gearrom_bench_quad] [--keep]
"""
from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _common import write_result

FS, LINES, RPM, Z1, Z2 = 2e6, 1000, 5830.0, 15, 30
CONFIG = Path(__file__).resolve().parents[1] / "tests" / "signal"


def write(folder: Path, seconds: float) -> Path:
    """Write the HDF5 record piece by piece (bounded memory) and its JSON."""
    import h5py

    sys.path.insert(0, str(CONFIG))
    from quad_synth import CONFIG as TOML, RB1, RB2, te_truth

    folder.mkdir(parents=True, exist_ok=True)
    (folder / "stage.toml").write_text(TOML.replace("rpm_in = 82.0", f"rpm_in = {RPM}"))
    n = int(seconds * FS)
    with h5py.File(folder / "rec.h5", "w") as f:
        ds = {k: f.create_dataset(k, (n,), dtype="i2") for k in ("input_a", "input_b", "output_a", "output_b")}
        step = 2_000_000
        for a in range(0, n, step):
            t = np.arange(a, min(n, a + step)) / FS
            th1 = 2 * math.pi * RPM / 60 * t
            th2 = (RB1 * th1 - te_truth(th1)) / RB2
            for name, th in (("input", th1), ("output", th2)):
                phi = LINES * th
                ds[f"{name}_a"][a:a + t.size] = (np.sin(phi) > 0) * 1000
                ds[f"{name}_b"][a:a + t.size] = (np.sin(phi - math.pi / 2) > 0) * 1000
    doc = {"format": "gearrom.measurement/1", "kind": "quadrature", "data": "rec.h5", "rpm_in": RPM,
           "config": "stage.toml", "sample_rate_hz": FS, "quadrature": {"threshold": 500, "hysteresis": 100},
           "encoders": {"input": {"lines": LINES}, "output": {"lines": LINES}}}
    path = folder / "rec.json"
    path.write_text(json.dumps(doc))
    return path


def child(path: str) -> None:
    t_imp = time.perf_counter()
    from gearrom.signal import process_measurement

    t0 = time.perf_counter()
    res = process_measurement(path)
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"wall_s": wall, "import_s": t0 - t_imp, "peak_MB": peak, "n_edges": res.n_edges,
                      "gmf_um": res.gmf_lines()[0][0] * 1e6, **accuracy(res)}))


def child_decode(path: str) -> None:
    from gearrom.signal.measurement import read_meta
    from gearrom.signal.qload import decode
    from gearrom.signal.settings import ReadSettings

    meta = read_meta(path)
    t0 = time.perf_counter()
    dec = decode(meta, ReadSettings())
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"wall_s": wall, "peak_MB": peak, "n_edges": {ch: int(v[0].size) for ch, v in dec.items()}}))


def accuracy(res) -> dict:
    """TE error against the emulated truth, um: rms and largest difference, after removing a line in the
    input angle (the angle detrend) and the truth's angle at the first edge (the angle origin)."""
    from scipy.optimize import minimize_scalar

    sys.path.insert(0, str(CONFIG))
    from quad_synth import TE_AMP, te_truth

    th, te = res.theta_in_rad, res.te_m
    sl = slice(th.size // 20, th.size - th.size // 20)  # the grid's ends hold the interpolation start/stop
    th, te = th[sl], te[sl]
    A = np.column_stack([np.ones_like(th), th - th.mean()])

    def err(d):
        tru = te_truth(th + d)
        e = te - tru
        return e - A @ np.linalg.lstsq(A, e, rcond=None)[0]

    step = 2 * math.pi / (4 * LINES)
    d = minimize_scalar(lambda d: float(np.mean(err(d) ** 2)), bounds=(-2 * step, 2 * step), method="bounded").x
    e = err(d)
    return {"te_error_rms_um": float(np.sqrt(np.mean(e ** 2)) * 1e6), "te_error_max_um": float(np.max(np.abs(e)) * 1e6),
            "te_truth_gmf_um": TE_AMP * 1e6, "first_edge_angle_rad": float(d)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--dir", default="/tmp/gearrom_bench_quad")
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--child")
    ap.add_argument("--child-decode")
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    if args.child_decode:
        child_decode(args.child_decode)
        return

    def run(flag: str) -> dict:
        out = subprocess.run([sys.executable, __file__, flag, str(path)], capture_output=True, text=True, check=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    path = write(Path(args.dir), args.seconds)
    rd = run("--child-decode")
    r = run("--child")
    dec_edges = sum(rd["n_edges"].values())
    edges = sum(r["n_edges"].values())
    samples = int(args.seconds * FS)
    figures = {"seconds": args.seconds, "sample_rate_hz": FS, "samples_per_channel": samples, "edges": edges,
               "wall_s": r["wall_s"], "edges_per_s": edges / r["wall_s"], "import_s": r["import_s"],
               "edges_per_s_with_import": edges / (r["wall_s"] + r["import_s"]), "samples_per_s": 4 * samples / r["wall_s"],
               "peak_MB": r["peak_MB"], "decode_wall_s": rd["wall_s"], "decode_edges": dec_edges,
               "decode_edges_per_s": dec_edges / rd["wall_s"], "decode_peak_MB": rd["peak_MB"], "data_MB": 4 * 2 * samples / 2**20, "gmf_um": r["gmf_um"],
               "target_edges_per_s": 5e6, "rpm_in": RPM, "samples_per_input_edge": FS / (RPM / 60 * 4 * LINES),
               **{k: r[k] for k in ("te_error_rms_um", "te_error_max_um", "te_truth_gmf_um", "first_edge_angle_rad")}}
    write_result("bench_signal_quadrature", figures)
    print(json.dumps(figures, indent=2))
    if not args.keep:
        for p in Path(args.dir).iterdir():
            p.unlink()


if __name__ == "__main__":
    main()
