"""``gearrom validate``: the pair ROM against the explicit transient FE at given input speeds."""
from __future__ import annotations

import json
import logging
import sys
from pathlib import Path

NAME = "validate"
HELP = ("compare the reduced model with the stored (or freshly run) explicit FE: DTE RMS, GMF 1-3 amplitude/phase "
        "(exit 1 if a speed misses the tolerances)")

log = logging.getLogger(__name__)


def add_args(parser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML file (spur pair)")
    parser.add_argument("--rpm", type=float, nargs="+", default=[1250.0, 2000.0], metavar="RPM",
                        help="input speeds [rev/min] (default 1250 2000)")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the report as JSON")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="overlay TE vs input angle and the spectra")
    parser.add_argument("--fe-dir", metavar="DIR",
                        help="folder of the stored explicit FE results spur_<rpm>rpm.npz/.json (default: validation/)")
    parser.add_argument("--fresh", action="store_true",
                        help="run a coarse explicit FE now (0.3 mm outline, 3 recorded mesh periods; minutes per speed)")
    parser.add_argument("--excitation", choices=("fe", "analytical", "auto"), default="fe",
                        help="mesh table of the ROM: quasi-static FE LTCA (default), analytical, or FE with fallback")
    parser.add_argument("--no-facets", action="store_true",
                        help="leave out the kinematic TE of the FE's faceted outlines (ideal involute ROM)")
    parser.add_argument("--table", choices=("ltca", "explicit_scaled"), default="ltca",
                        help="ROM mesh table: the quasi-static LTCA (default), or the LTCA scaled to the explicit FE's "
                             "own static compliance (stored spur records only; see validation/"
                             "rom_vs_fe_spur_same_discretization.json)")
    parser.add_argument("--fe-integration", choices=("loaded", "full", "reduced"), default=None,
                        help="stored explicit FE records: the references from the loaded static state with calibrated "
                             "damping (spur_<rpm>rpm_loaded.*), fully integrated Q4 from a gap without damping "
                             "(spur_<rpm>rpm_full.*) or one-point Q4 with hourglass control (spur_<rpm>rpm.*); "
                             "default: per speed the first of these that is stored")
    parser.add_argument("--rom", choices=("pair", "exudyn", "exudyn-bodies"), default=None,
                        help="reduced model: 1-DOF pair ROM with the FE's torque ramp, the same system as an exudyn "
                             "Drivetrain (the project's drivetrain ROM), or that Drivetrain with flexible gear bodies "
                             "(rim on hub, from the FE's meshes); default: exudyn for loaded-start records, "
                             "pair for the others")
    parser.add_argument("--damping-ratio", type=float, default=None,
                        help="ROM mesh damping ratio (default: the FE record's: its calibrated ratio for loaded-start "
                             "records, 0 for fully integrated undamped records, 0.01 for one-point records)")


#: Highest input speed accepted, rpm.
RPM_LIMIT = 1e5
#: Highest ROM mesh damping ratio accepted (ten times critical).
DAMPING_LIMIT = 10.0


def check_args(args) -> None:
    """Check the options before the ROM and FE run (one-line errors naming the option)."""
    from gearrom.cli._args import PLOT_SUFFIXES, check_input_dir, check_number, check_output

    for r in args.rpm:
        check_number("--rpm", r, gt=0, le=RPM_LIMIT, unit="rpm")
    check_number("--damping-ratio", args.damping_ratio, ge=0, le=DAMPING_LIMIT)
    args.json = check_output("--json", args.json, what="JSON file")
    args.plot = check_output("--plot", args.plot, PLOT_SUFFIXES, what="figure")
    args.fe_dir = check_input_dir("--fe-dir", args.fe_dir)


def run(args) -> int:
    """Compare ROM and FE; options checked first, the JSON report written before the figure."""
    from gearrom.cli._args import prepare_output
    from gearrom.validation.report import validate

    check_args(args)
    rep = validate(args.config, args.rpm, fe_dir=args.fe_dir, fresh=args.fresh, excitation_source=args.excitation,
                   damping_ratio=args.damping_ratio, facets=not args.no_facets, table=args.table,
                   rom_model=args.rom, fe_integration=args.fe_integration)
    out = rep.to_dict()
    if args.json:
        rep.save(args.json)
    if args.plot:
        fig = rep.plot()
        fig.savefig(prepare_output(args.plot), dpi=120)
    lines = [f"{out['config']}: ROM vs explicit FE"]
    for s in out["speeds"]:
        lines.append(f"  {s['rpm_in']:g} rpm (FE {s['fe_source']}): {'PASS' if s['passed'] else 'FAIL'}")
        for key, m in s["metrics"].items():
            err = f"{100 * m['rel_error']:+.1f} %" if "rel_error" in m else f"{m['error_deg']:+.1f} deg"
            note = "  (below the FE noise floor: not judged)" if m.get("below_floor") else ""
            lines.append(f"    {key:20s} rom {m['rom']:9.3f}  fe {m['fe']:9.3f}  {err}{note}")
        g = s["gates"]
        lines.append(f"    FE gates {'pass' if g['passed'] else 'FAIL'}: non-periodic {100 * g['nonperiodic_share']:.1f} %, "
                     f"drift {100 * g['drift_rel_gmf1']:.1f} % of GMF1"
                     + ("" if g["energy_error_rel"] is None else f", energy {100 * g['energy_error_rel']:.2g} %")
                     + f"; noise floor {g['noise_floor_um']:.4f} um")
        for miss in s["misses"]:
            lines.append(f"    miss: {miss}")
    if not args.json:
        lines.append(json.dumps(out, default=float))
    sys.stdout.write("\n".join(lines) + "\n")
    return 0 if out["passed"] else 1
