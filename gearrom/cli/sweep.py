"""``gearrom sweep NAME_OR_PATH --rpm 250:5000:25 --out DIR``: dynamic TE over a speed range (exudyn ROM).

Writes ``DIR/speeds/*.nc`` (one per speed, reused by a rerun into the same ``DIR`` when nothing the
speed depends on has changed, see :func:`gearrom.rom.sweep.reuse_key`), ``DIR/sweep.nc`` (xarray
dataset), ``DIR/summary.json``, ``DIR/waterfall.png`` (DTE spectrum vs speed) and
``DIR/gmf_vs_speed.png`` (time-domain GMF harmonics with the python-control linear estimate
overlaid). Every file is written to a temporary file and renamed into place.
"""
from __future__ import annotations

import argparse
import io
import json
import math
import sys
import time
import warnings

import numpy as np

from gearrom.cli._args import check_load_torque, check_output_dir
from gearrom.config import GearConfig, load_config
from gearrom.errors import ConfigError

NAME = "sweep"
HELP = "dynamic transmission error over a speed range (reduced-order exudyn model)"
#: bounds of the sweep settings: worker processes and samples per speed (memory of one run)
MAX_PROCESSES = 256
MAX_SAMPLES = 2e7
SWEEP_KEYS = {"rpm": "speeds 'START:STOP:STEP' [rpm]", "output_revolutions": "recorded output revolutions per speed",
              "samples_per_mesh": "samples per mesh period", "processes": "worker processes"}


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML path")
    parser.add_argument("--rpm", help="input speeds START:STOP:STEP or a comma list [rpm] (default: [sweep] rpm, "
                                      "else 250:5000:250)")
    parser.add_argument("--out", required=True, help="output directory (reused to resume)")
    parser.add_argument("--processes", type=int, help="worker processes (default: [sweep] processes, else 2)")
    parser.add_argument("--revs", type=float, help="recorded output revolutions per speed (default 2)")
    parser.add_argument("--torque", type=float, help="load torque [N m] (default: operating.torque_out_Nm)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-linear", action="store_true", help="skip the python-control linear estimate")


def sweep_settings(cfg, args) -> dict:
    """Merge the config's ``[sweep]`` section with the command line; validate."""
    sec = cfg.section("sweep")
    for key in sec:
        if key not in SWEEP_KEYS:
            raise ConfigError(f"{cfg.source}: unknown key 'sweep.{key}' (known: {', '.join(SWEEP_KEYS)})")
    out = {"rpm": sec.get("rpm", "250:5000:250"), "output_revolutions": sec.get("output_revolutions", 2.0),
           "samples_per_mesh": sec.get("samples_per_mesh", 32), "processes": sec.get("processes", 2)}
    for key, typ in (("output_revolutions", (int, float)), ("samples_per_mesh", int), ("processes", int)):
        v = out[key]
        if isinstance(v, bool) or not isinstance(v, typ) or not v > 0:
            raise ConfigError(f"{cfg.source}: sweep.{key} must be a positive {'integer' if typ is int else 'number'}, got {v!r}")
    if args.rpm is not None:
        out["rpm"] = args.rpm
    if args.processes is not None:
        out["processes"] = args.processes
    if args.revs is not None:
        out["output_revolutions"] = args.revs
    src = lambda opt, key: opt if getattr(args, opt[2:]) is not None else f"{cfg.source}: sweep.{key}"  # noqa: E731
    if not 1 <= out["processes"] <= MAX_PROCESSES:
        raise ConfigError(f"{src('--processes', 'processes')} must be in 1..{MAX_PROCESSES} worker processes, "
                          f"got {out['processes']}")
    revs, z2 = float(out["output_revolutions"]), cfg.pair.z[1]
    samples = revs * z2 * out["samples_per_mesh"] if math.isfinite(revs) else math.inf
    if not (math.isfinite(revs) and revs * z2 >= 1 and samples <= MAX_SAMPLES):
        raise ConfigError(f"{src('--revs', 'output_revolutions')} must record at least one mesh period (>= "
                          f"{1 / z2:.4g} output revolutions for z2 = {z2}) and at most {MAX_SAMPLES:.0e} samples "
                          f"per speed, got {revs:g} revolutions")
    check_load_torque("--torque", args.torque, cfg.operating.torque_out)
    return out


def _describe(exc: dict) -> str:
    """One line on the excitation a sweep ran on (source, torques, FE cache key)."""
    src = exc.get("source", "?")
    text = {"fe": "quasi-static FE tables", "analytical": "ISO 6336-1 shaped analytical table"}.get(src, f"table {src}")
    tq = exc.get("torques_Nm") or []
    if tq:
        text += f" at {', '.join(f'{t:g}' for t in tq)} N m"
    return text + (f" (FE cache key {exc['cache_key']})" if exc.get("cache_key") else "")


def _check_repeats(rpms: np.ndarray, st: dict, cfg: GearConfig, args: argparse.Namespace) -> None:
    """Reject a speed given twice, naming where the speeds came from (``--rpm`` or ``sweep.rpm``)."""
    from gearrom.rom.sweep import repeated_speeds

    repeats = repeated_speeds(rpms)
    if repeats:
        where = f"--rpm {args.rpm!r}" if args.rpm is not None else f"{cfg.source}: sweep.rpm {st['rpm']!r}"
        raise ConfigError(f"{where} gives {', '.join(f'{r:g}' for r in repeats)} rpm more than once; "
                          f"list each speed once")


def run(args: argparse.Namespace) -> int:
    from gearrom.rom.sweep import parse_rpm, run_sweep, write_bytes_atomic, write_text_atomic

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config(args.config)
    st = sweep_settings(cfg, args)
    where = f"--rpm {args.rpm!r}" if args.rpm is not None else f"{cfg.source}: sweep.rpm {st['rpm']!r}"
    try:
        rpms = parse_rpm(st["rpm"])
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    _check_repeats(rpms, st, cfg, args)
    args.out = check_output_dir("--out", args.out)
    t0 = time.perf_counter()
    res = run_sweep(args.config, rpms, args.out, torque_out=args.torque, processes=st["processes"],
                    n_output_revs=float(st["output_revolutions"]), samples_per_mesh=st["samples_per_mesh"],
                    progress=not args.no_progress, linear=not args.no_linear)
    wall = time.perf_counter() - t0
    res.save(args.out / "sweep.nc")
    summary = res.summary_json()
    write_text_atomic(json.dumps(summary, indent=1) + "\n", args.out / "summary.json")
    for name, fig in (("waterfall.png", res.plot()), ("gmf_vs_speed.png", res.plot_gmf())):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=120)
        write_bytes_atomic(buf.getvalue(), args.out / name)
    n_loss = sum(s["contact_loss"] for s in res.summary)
    worst = max(res.summary, key=lambda s: s["dte_ptp_um"])
    sys.stdout.write(
        f"sweep {cfg.name}: {len(rpms)} speeds {rpms[0]:.0f}-{rpms[-1]:.0f} rpm in {wall:.1f} s wall\n"
        f"  excitation: {_describe(res.metadata.get('excitation', {}))}\n"
        f"  largest DTE (sensor side) {worst['dte_ptp_um']:.3f} um p-p at {worst['rpm_in']:.0f} rpm; "
        f"contact loss at {n_loss} speed(s)\n"
        f"  written: {args.out}/summary.json, sweep.nc, waterfall.png, gmf_vs_speed.png, speeds/\n")
    return 0

