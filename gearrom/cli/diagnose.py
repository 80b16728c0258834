"""``gearrom diagnose NAME_OR_PATH MEASUREMENT.json [...]``: which effect does the model miss, and how big is it."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "diagnose"
HELP = "compare measured runs with the model, trace and fit the missing effects, report error before/after"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``gearrom diagnose``."""
    parser.add_argument("config", metavar="NAME_OR_PATH", help="gear/rig configuration (bundled name or TOML file)")
    parser.add_argument("measurements", metavar="MEASUREMENT.json", nargs="+", type=Path,
                        help="one or more gearrom.measurement/1 files of the same rig (different speeds/loads)")
    parser.add_argument("--json", dest="json_out", metavar="OUT", help="write the report JSON here ('-' = stdout)")
    parser.add_argument("--report", metavar="DIR",
                        help="write diagnosis.json, summary.txt and before/after plots (run_<i>.png) into DIR")
    parser.add_argument("--save", metavar="NPZ", type=Path, help="save the full result (traces + JSON)")
    parser.add_argument("--write-config", metavar="OUT.toml", type=Path,
                        help="write a config that extends NAME_OR_PATH with the found effects (runout, pitch "
                             "deviations, flank modifications, rig parameters): `gearrom sweep OUT.toml` runs it")
    parser.add_argument("--simulator", choices=("auto", "rom", "torsional"), default="auto",
                        help="dynamic model: the exudyn ROM, the torsional rig model, or auto (the ROM when the "
                             "config describes a rig, as thesis-rig; else the torsional rig model)")
    parser.add_argument("--torque-out-Nm", type=float, help="load torque for files that do not state torque_out_Nm")
    parser.add_argument("--max-effects", type=int, default=3, help="most effects added (default 3)")
    parser.add_argument("--effects", help="comma-separated subset of the library to consider "
                        "(eccentricity,pitch_error,tip_relief,lead_crowning,helix_slope,encoder_eccentricity,torsional_mode)")
    parser.add_argument("--rig-parameters", metavar="NAMES",
                        help="comma-separated rig parameters torsional_mode may re-tune (default: k_clutch,J_motor,"
                             "J_load,k_shaft_in,mesh_stiffness,k_support, those the simulator offers; k_support scales "
                             "the bearing supports over 0.1-100 x)")
    parser.add_argument("--per-run-phase", action="store_true",
                        help="shaft-order phases per run (the default; kept for compatibility)")
    parser.add_argument("--shared-phase", action="store_true",
                        help="one shaft-order phase for all runs: only when every file starts at the encoder index")
    parser.add_argument("--micro-model", choices=("fe", "slices"), default="fe",
                        help="flank modifications through the quasi-static FE tables (default; no FE solve per "
                             "modification, the FE cache is built once per gear) or the analytical thin slices")
    parser.add_argument("--rpm-tolerance", type=float,
                        help="allowed relative mismatch of rpm_in and the data (default: the config's [signal] "
                             "rpm_tolerance, else 0.05)")
    parser.add_argument("--allow-outside-data", action="store_true",
                        help="read data files outside their measurement JSON's folder (refused by default)")
    from gearrom.cli.te import add_read_args

    add_read_args(parser)


#: Largest ``--max-effects`` accepted (the library has fewer effects; a larger count changes nothing).
MAX_EFFECTS_LIMIT = 64
#: Largest ``--torque-out-Nm`` magnitude accepted, N m.
TORQUE_LIMIT_NM = 1e7


def check_args(args: argparse.Namespace) -> tuple[str, ...] | None:
    """Check the options and the measurement files' metadata before the (minutes long) diagnosis.

    Returns the effect names of ``--effects`` (None: the whole library).
    """
    from gearrom.calibrate import check_name
    from gearrom.cli._args import check_number, check_output, check_output_dir
    from gearrom.errors import CalibrationError, ConfigError
    from gearrom.signal import read_meta

    check_number("--torque-out-Nm", args.torque_out_Nm, ge=-TORQUE_LIMIT_NM, le=TORQUE_LIMIT_NM, unit="N m")
    check_number("--max-effects", args.max_effects, ge=0, le=MAX_EFFECTS_LIMIT, integer=True)
    check_number("--rpm-tolerance", args.rpm_tolerance, gt=0, le=1)
    from gearrom.cli.te import check_read_args

    check_read_args(args)
    args.json_out = check_output("--json", args.json_out, stdout=True, what="JSON file")
    args.report = check_output_dir("--report", args.report)
    args.save = check_output("--save", args.save, what="result file")
    args.write_config = check_output("--write-config", args.write_config, (".toml",), what="config file")
    names = None
    if args.effects is not None:
        names = tuple(x.strip() for x in args.effects.split(",") if x.strip())
        if not names:
            raise ConfigError(f"--effects={args.effects!r}: names no effect")
        for n in names:
            try:
                check_name(n)
            except CalibrationError as exc:
                raise CalibrationError(f"--effects={args.effects!r}: {exc}") from None
    if args.rig_parameters is not None:
        from gearrom.calibrate.simulator import ROM_TUNABLE
        from gearrom.calibrate.torsional import TUNABLE

        rig_parameter_names(args.rig_parameters, {**TUNABLE, **{k: v.description for k, v in ROM_TUNABLE.items()}},
                            "the ROM or the torsional rig model")
    for path in args.measurements:
        meta = read_meta(path)
        if meta.torque_out_Nm is None and args.torque_out_Nm is None:
            raise CalibrationError(f"{path}: 'torque_out_Nm' is missing in the measurement and was not given "
                                   "(--torque-out-Nm)")
    return names


def rig_parameter_names(text: str, offered, by: str) -> tuple[str, ...]:
    """The names of ``--rig-parameters``, each one in ``offered`` (the parameters ``by`` can scale).

    Raises
    ------
    CalibrationError
        An empty list or a name not offered (the offered ones are listed).
    """
    from gearrom.errors import CalibrationError

    names = tuple(x.strip() for x in text.split(",") if x.strip())
    if not names:
        raise CalibrationError(f"--rig-parameters={text!r}: names no parameter")
    unknown = [n for n in names if n not in offered]
    if unknown:
        raise CalibrationError(f"--rig-parameters={text!r}: {', '.join(unknown)} cannot be scaled by {by} "
                               f"(offered: {', '.join(sorted(offered))})")
    return names


def run(args: argparse.Namespace) -> int:
    """Run the diagnosis and write the requested outputs.

    Everything that can be checked is checked before the diagnosis starts; afterwards the report
    JSON (the expensive result, plain text) is written first, missing folders are created, and
    the figures come last.
    """
    from gearrom.calibrate import FitSettings, diagnose
    from gearrom.calibrate.simulator import default_simulator
    from gearrom.cli._args import prepare_output
    import dataclasses

    from gearrom.cli.te import OPTION_KEYS, read_overrides
    from gearrom.signal.config import settings_from_config

    names = check_args(args)
    # the reader follows the config's [signal] section (edge checks, window, trimming), options override it
    te_settings, read_settings = settings_from_config(args.config, {"rpm_tolerance": args.rpm_tolerance, **read_overrides(args)},
                                            OPTION_KEYS)
    read_settings = dataclasses.replace(read_settings, allow_outside_data=args.allow_outside_data)
    settings = FitSettings(max_effects=args.max_effects, candidates=names, shared_shaft_phase=args.shared_phase and not args.per_run_phase)
    sim = default_simulator(args.config, prefer=args.simulator)
    if args.rig_parameters is not None:
        offered = sim.tunable() if hasattr(sim, "tunable") else {}
        settings = dataclasses.replace(settings, rig_parameters=rig_parameter_names(
            args.rig_parameters, offered, f"the {getattr(sim, 'name', 'simulator')}"))
    micro = None
    if args.micro_model == "slices":
        from gearrom.excitation.slices import SliceMicroModel

        micro = SliceMicroModel()
        sim.micro_model = micro  # the re-simulations use the same micro-geometry model as the fits
    res = diagnose(args.config, args.measurements, simulator=sim, settings=settings, micro_model=micro,
                   read_settings=read_settings, te_settings=te_settings, torque_out_Nm=args.torque_out_Nm)
    if args.json_out == "-":
        sys.stdout.write(res.to_json())
    elif args.json_out:
        prepare_output(args.json_out).write_text(res.to_json())
    if args.save:
        res.save(prepare_output(args.save))
    if args.write_config:
        from gearrom.calibrate.writeconfig import write_config

        write_config(res.summary, args.config, prepare_output(args.write_config))
    if args.json_out != "-":
        sys.stdout.write(res.text())
    if args.report:
        res.write_report(args.report)
    return 0
