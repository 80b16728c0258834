"""``gearrom tolerance NAME_OR_PATH --samples N [--scheduler ADDRESS] [--out DIR]``: TE scatter over tolerances.

Samples manufacturing deviations within ISO 1328-1 grade ``--grade`` (or the drawing tolerances of
``--tolerances FILE.toml``), runs the ROM over the speeds per sample on dask.distributed (embedded
LocalCluster, or the scheduler at ``--scheduler``), one file per sample in ``DIR/samples`` (a rerun
resumes). Writes ``DIR/tolerance.nc``, ``DIR/tolerance_summary.json`` (P5/P50/P95 vs speed,
sensitivity ranking) and ``DIR/tolerance.png``.
"""
from __future__ import annotations

import argparse
import io
import json
import sys
import time
import warnings

from gearrom.cli._args import check_load_torque, check_number, check_output_dir, check_rpm_spec
from gearrom.errors import ConfigError

NAME = "tolerance"
HELP = "scatter of the dynamic TE over manufacturing tolerances (ROM sweeps per sample on dask)"
MAX_SAMPLES = 1_000_000


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML path")
    parser.add_argument("--samples", type=int, required=True, help="number of samples")
    parser.add_argument("--out", default="out/tolerance", help="output directory, reused to resume (default out/tolerance)")
    parser.add_argument("--scheduler", help="address of a running dask scheduler, tcp://host:port (default: embedded)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the embedded cluster (default 2)")
    parser.add_argument("--rpm", default="250:5000:250", help="speeds START:STOP:STEP or a list [rpm]")
    parser.add_argument("--grade", type=int, default=6, help="ISO 1328-1:2013 flank tolerance class (default 6)")
    parser.add_argument("--tolerances", help="TOML file with a [tolerance] table of drawing tolerances (um)")
    parser.add_argument("--revs", type=float, default=1.0, help="recorded output revolutions per speed (default 1)")
    parser.add_argument("--samples-per-mesh", type=int, default=64, help="samples per mesh period (default 64)")
    parser.add_argument("--micro", choices=("fe", "slices", "none"), default="fe",
                        help="flank modifications through the FE contact (cached compliances), thin slices, or none")
    parser.add_argument("--torque", type=float, help="load torque [N m] (default: operating.torque_out_Nm)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample generator")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from gearrom.config import load_config
    from gearrom.rom.sweep import parse_rpm, write_bytes_atomic, write_text_atomic
    from gearrom.study.scatter import default_settings, run_tolerance_study
    from gearrom.study.tolerance import ToleranceSpec

    check_number("--samples", args.samples, ge=1, le=MAX_SAMPLES, integer=True)
    check_number("--workers", args.workers, ge=1, le=256, integer=True)
    check_number("--grade", args.grade, ge=1, le=11, integer=True)
    check_number("--revs", args.revs, gt=0, le=100)
    check_number("--samples-per-mesh", args.samples_per_mesh, ge=4, le=1024, integer=True)
    check_number("--seed", args.seed, ge=0, integer=True)
    check_rpm_spec("--rpm", args.rpm)
    if args.scheduler is not None and not str(args.scheduler).strip():
        raise ConfigError(f"--scheduler={args.scheduler!r}: give an address such as tcp://host:8786")
    out = check_output_dir("--out", args.out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config(args.config)
    check_load_torque("--torque", args.torque, cfg.operating.torque_out)
    if args.revs * cfg.pair.z[1] < 1:
        raise ConfigError(f"--revs={args.revs!r}: must record at least one mesh period (>= {1 / cfg.pair.z[1]:.4g})")
    rpms = parse_rpm(args.rpm)
    spec = ToleranceSpec.from_toml(args.tolerances, cfg.pair, args.grade) if args.tolerances else \
        ToleranceSpec.from_grade(cfg.pair, args.grade)
    st = default_settings(cfg, rpms, args.torque, args.revs, args.samples_per_mesh, args.micro)
    t0 = time.perf_counter()
    res = run_tolerance_study(args.config, spec, args.samples, st, out, seed=args.seed, scheduler=args.scheduler,
                              n_workers=args.workers, progress=not args.no_progress)
    wall = time.perf_counter() - t0
    res.save(out / "tolerance.nc")
    summary = res.summary_json()
    summary["wall_s"] = wall
    write_text_atomic(json.dumps(summary, indent=1, default=float) + "\n", out / "tolerance_summary.json")
    fig = res.plot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    write_bytes_atomic(buf.getvalue(), out / "tolerance.png")
    top = ", ".join(f"{n} ({v:.2f})" for n, v in res.sensitivity("gmf1")[:3])
    sys.stdout.write(f"tolerance {cfg.name}: {args.samples} samples x {len(rpms)} speeds in {wall:.1f} s wall "
                     f"({res.metadata['reused']} reused); {spec.source}\n"
                     f"  most influential on GMF x1: {top}\n"
                     f"  written: {out}/tolerance.nc, tolerance_summary.json, tolerance.png, samples/\n")
    return 0
