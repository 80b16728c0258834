"""``gearrom ccx-te DECK.inp``: the static TE of a deck written by ``gearrom stiffness --inp`` and solved by ccx."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

NAME = "ccx-te"
HELP = "read the static TE out of the CalculiX result of a deck written by 'gearrom stiffness --inp'"


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("deck", type=Path, metavar="DECK.inp", help="the deck (its readout line names the node)")
    parser.add_argument("--dat", type=Path, help="ccx result file (default: the deck's path with suffix .dat)")
    parser.add_argument("--run", action="store_true", help="run ccx on the deck first (ccx must be on PATH)")
    parser.add_argument("--threads", type=int, default=2, help="threads for ccx with --run (default 2)")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the result as JSON")


def run(args: argparse.Namespace) -> int:
    from gearrom.errors import ConfigError
    from gearrom.fe.ccx import read_readout, read_static_te, run_ccx

    if args.threads < 1:
        raise ConfigError(f"--threads must be >= 1, got {args.threads}")
    read_readout(args.deck)  # a deck without a readout line fails before ccx runs
    wall = run_ccx(args.deck, args.threads) if args.run else None
    res = read_static_te(args.deck, args.dat)
    if wall is not None:
        res["ccx_wall_s"] = wall
    line = f"{args.deck}: static TE {res['ste_um']:.4f} um at output torque {res['torque_out_Nm']:.4g} N m"
    if "ltca_ste_um" in res:
        line += f"; LTCA {res['ltca_ste_um']:.4f} um (ccx/LTCA = {res['ratio_to_ltca']:.4f})"
    sys.stdout.write(line + (f"; ccx {wall:.1f} s" if wall is not None else "") + "\n")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(res, indent=1) + "\n")
    return 0
