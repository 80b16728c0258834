"""``gearrom campbell NAME_OR_PATH [--json OUT] [--plot PNG]``: modes, mesh energy share, Campbell diagram."""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from gearrom.config import load_config

NAME = "campbell"
HELP = "natural frequencies, mesh strain-energy share and Campbell diagram of the drivetrain"


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML path")
    parser.add_argument("--json", type=Path, help="write modes and crossings as JSON here")
    parser.add_argument("--plot", type=Path, help="write the Campbell diagram (PNG) here")
    parser.add_argument("--rpm", default=None, help="speed grid START:STOP:STEP [rpm] (default: [sweep] range, 25 points)")
    parser.add_argument("--fmax", type=float, help="highest frequency [Hz] (default 1.2 x 3rd GMF at top speed)")
    parser.add_argument("--min-share", type=float, default=0.01,
                        help="list crossings of modes with at least this mesh energy share (default 0.01)")


#: Highest ``--fmax`` accepted, Hz.
FMAX_LIMIT_HZ = 1e6


def check_args(args: argparse.Namespace) -> None:
    """Check the options before the model is built (one-line errors naming the option)."""
    from gearrom.cli._args import PLOT_SUFFIXES, check_number, check_output, check_rpm_spec

    check_number("--fmax", args.fmax, gt=0, le=FMAX_LIMIT_HZ, unit="Hz")
    check_number("--min-share", args.min_share, ge=0, le=1)
    check_rpm_spec("--rpm", args.rpm)
    args.json = check_output("--json", args.json, what="JSON file")
    args.plot = check_output("--plot", args.plot, PLOT_SUFFIXES, what="figure")


def run(args: argparse.Namespace) -> int:
    """Modes and Campbell diagram; options checked first, the JSON written before the figure."""
    import numpy as np

    from gearrom.cli._args import prepare_output

    check_args(args)

    from gearrom.rom.modal import campbell, modal_analysis
    from gearrom.rom.rig import build_rig
    from gearrom.rom.sweep import parse_rpm

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config(args.config)
    if args.rpm is None:
        r = parse_rpm(cfg.section("sweep").get("rpm", "250:5000:250"))
        rpm = np.linspace(r.min(), r.max(), 25) if r.size > 1 else r
    else:
        rpm = parse_rpm(args.rpm)
    model = build_rig(cfg)
    res = campbell(model, rpm, fmax=args.fmax, min_share=args.min_share)
    modes = modal_analysis(model, float(rpm[0]), fmax=res.freqs.max() * 1.001)
    # all arrays included: the file reads back with CampbellResult.load
    out = {**res.to_json(), "freqs_Hz": res.freqs.tolist(), "mesh_share": res.mesh_share.tolist(),
           "modes": modes.table()}
    if args.json:
        prepare_output(args.json).write_text(json.dumps(out, indent=1) + "\n")
    if args.plot:
        fig = res.plot(args.fmax)
        fig.savefig(prepare_output(args.plot), dpi=120)
    lines = [f"campbell {cfg.name}: {len(modes.freqs)} modes below {res.freqs.max():.0f} Hz at {rpm[0]:.0f} rpm",
             f"  {'mode':>4s} {'f [Hz]':>9s} {'zeta':>6s} {'mesh E':>7s}  dominant DOFs"]
    for m in modes.table():
        lines.append(f"  {m['mode']:4d} {m['frequency_Hz']:9.1f} {m['damping_ratio']:6.3f} {m['mesh_energy_share']:7.3f}  "
                     f"{', '.join(m['dominant_dofs'])}")
    lines.append(f"  crossings (mesh energy share >= {args.min_share}):")
    for c in res.crossings:
        lines.append(f"    {c['order']:>12s} x mode {c['mode']:2d}: {c['rpm_in']:7.0f} rpm, {c['frequency_Hz']:7.0f} Hz, "
                     f"mesh share {c['mesh_energy_share']:.3f}")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
