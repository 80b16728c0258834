"""``gearrom runup NAME_OR_PATH --rpm 250:5000 --duration-s T --out DIR``: speed ramp with order tracking.

Writes ``DIR/runup.nc`` (order spectrum vs speed and GMF x1-3 of the DTE, xarray/NetCDF),
``DIR/runup.png`` (colour map; with the stepped-sweep comparison when ``--compare N`` > 0) and
``DIR/runup_summary.json`` (ramp, cost, and the comparison: run-up / stepped sweep - 1 at N speeds).
"""
from __future__ import annotations

import argparse
import io
import json
import math
import sys
import warnings

import numpy as np

from gearrom.cli._args import check_load_torque, check_number, check_output_dir
from gearrom.errors import ConfigError

NAME = "runup"
HELP = "continuous speed ramp of the ROM with order tracking of the DTE (as a rig measures a run-up)"
#: longest ramp accepted [s] (memory of the time-domain recording grows ~35 MB per simulated s at 5000 rpm)
MAX_DURATION_S = 120.0


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML path")
    parser.add_argument("--rpm", required=True, help="ramp START:END [rpm], START < END")
    parser.add_argument("--duration-s", type=float, required=True, help="ramp duration [s]")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--torque", type=float, help="load torque [N m] (default: operating.torque_out_Nm)")
    parser.add_argument("--samples-per-mesh", type=int, default=64, help="samples per mesh period (default 64)")
    parser.add_argument("--compare", type=int, default=8,
                        help="stepped steady-state runs to compare with, evenly over the ramp (0: none; default 8)")


def parse_ramp(spec: str) -> tuple[float, float]:
    """``"START:END"`` -> (start, end) [rpm]; ConfigError naming ``--rpm`` otherwise."""
    try:
        a, b = (float(v) for v in str(spec).split(":"))
    except ValueError:
        raise ConfigError(f"--rpm={spec!r}: must be START:END [rpm]") from None
    if not (math.isfinite(a) and math.isfinite(b) and 0 < a < b <= 1e5):
        raise ConfigError(f"--rpm={spec!r}: needs 0 < START < END <= 1e5 rpm")
    return a, b


def run(args: argparse.Namespace) -> int:
    from gearrom.config import load_config
    from gearrom.rom.sweep import write_bytes_atomic, write_text_atomic
    from gearrom.study.runup import compare_with_sweep, simulate_runup

    a, b = parse_ramp(args.rpm)
    check_number("--duration-s", args.duration_s, gt=0, le=MAX_DURATION_S, unit="s")
    check_number("--samples-per-mesh", args.samples_per_mesh, ge=8, le=1024, integer=True)
    check_number("--compare", args.compare, ge=0, le=200, integer=True)
    out = check_output_dir("--out", args.out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config(args.config)
    check_load_torque("--torque", args.torque, cfg.operating.torque_out)
    from gearrom.rom.rig import build_rig

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = build_rig(cfg, torque_out=args.torque)
    res = simulate_runup(model, a, b, args.duration_s, args.torque, samples_per_mesh=args.samples_per_mesh)
    cmp = None
    if args.compare:
        lo, hi = res.rpm[0], res.rpm[-1]
        cmp = compare_with_sweep(res, model, np.linspace(lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo), args.compare),
                                 args.torque, samples_per_mesh=args.samples_per_mesh)
    out.mkdir(parents=True, exist_ok=True)
    res.save(out / "runup.nc")
    fig = res.plot(compare=cmp)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    write_bytes_atomic(buf.getvalue(), out / "runup.png")
    summary = {"config": cfg.name, **res.metadata, "comparison_with_stepped_sweep": cmp}
    write_text_atomic(json.dumps(summary, indent=1, default=float) + "\n", out / "runup_summary.json")
    msg = (f"runup {cfg.name}: {a:g}-{b:g} rpm in {args.duration_s:g} s ({res.ramp_rate_rpm_per_s:.0f} rpm/s), "
           f"{len(res.rpm)} order blocks, {res.metadata['wall_s']:.1f} s wall\n")
    if cmp:
        d = np.abs(np.array(cmp["rel_diff"])[:, 0])
        msg += f"  GMF x1 vs stepped sweep at {len(d)} speeds: largest |difference| {100 * d.max():.1f} %\n"
    sys.stdout.write(msg + f"  written: {out}/runup.nc, runup.png, runup_summary.json\n")
    return 0
