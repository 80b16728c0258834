"""``gearrom te MEASUREMENT.json``: transmission error of a measured (or emulated) run."""
from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

NAME = "te"
HELP = "transmission error, spectra and GMF lines of a gearrom.measurement/1 file"

log = logging.getLogger(__name__)


def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``gearrom te``. Processing options default to the config's ``[signal]`` section."""
    parser.add_argument("measurement", type=Path, help="measurement JSON (format gearrom.measurement/1)")
    parser.add_argument("--json", dest="json_out", metavar="OUT", help="write the summary JSON here ('-' = stdout)")
    parser.add_argument("--plot", metavar="PNG", type=Path, help="write a figure (TE, spectrum, averages)")
    parser.add_argument("--save", metavar="NPZ", type=Path, help="save the full TE result (.npz, TEResult.load)")
    parser.add_argument("--config", metavar="NAME_OR_PATH",
                        help="gear configuration: z, radii and [signal] defaults (default: the measurement's "
                             "'config' key, else thesis-helical)")
    parser.add_argument("--te-on", choices=("line", "pitch"),
                        help="TE along the line of action (base radii, default) or on the pitch circle (seed eq. 38-40)")
    g = parser.add_argument_group("filters (defaults: the config's [signal] section, else as stated)")
    g.add_argument("--lowpass-hz", type=float, help="Bessel low-pass cut-off [Hz] (-3 dB of one pass); default none")
    g.add_argument("--lowpass-order", type=int, help="Bessel low-pass order (default 4)")
    g.add_argument("--highpass-hz", type=float, help="Butterworth high-pass cut-off for drift [Hz]; default none")
    g.add_argument("--causal", action="store_true", help="causal filtering instead of zero-phase (forward-backward)")
    g.add_argument("--detrend", choices=("angle", "linear", "constant", "none"),
                   help="trend removed before filtering (default angle: offset and nominal slope as a line in the "
                        "input angle, valid for run-ups; linear: a line in time)")
    r = parser.add_argument_group("reader")
    r.add_argument("--fs-hz", type=float, help="rate of the common time grid [Hz] (default: from the edge rate)")
    r.add_argument("--rpm-tolerance", type=float, help="allowed relative mismatch of rpm_in and the data (default 0.05)")
    r.add_argument("--strict", action="store_true", help="fail on anything that would need a repair")
    r.add_argument("--edge-interp", choices=("cubic", "linear"), help="angle between encoder edges (default cubic)")
    r.add_argument("--allow-outside-data", action="store_true",
                   help="read a data file outside the measurement JSON's folder (refused by default)")
    add_read_args(parser)


def add_read_args(parser: argparse.ArgumentParser, scale: bool = True) -> None:
    """Edge-check and time-window options shared by ``gearrom te`` and ``gearrom diagnose``; with
    ``scale`` also the speed-ratio tolerance and the encoder-scale estimate (TE settings)."""
    c = parser.add_argument_group("edge checks and time window (defaults: the config's [signal] section)")
    c.add_argument("--t-start", type=float, metavar="S", help="use the record from this time [s]")
    c.add_argument("--t-end", type=float, metavar="S", help="use the record up to this time [s]")
    c.add_argument("--no-trim", action="store_true",
                   help="sampled records: keep standstill (a reversal is then an error) instead of cutting it")
    c.add_argument("--min-speed-fraction", type=float,
                   help="standstill for trimming: slower than this fraction of the highest speed (default 0.05)")
    c.add_argument("--double-ratio", type=float, help="interval/reference below which an edge is spurious (0.5)")
    c.add_argument("--gap-ratio", type=float, help="interval/reference above which edges were dropped (1.5)")
    c.add_argument("--integer-tol", type=float, help="largest distance from a whole number of dropped edges (0.3)")
    c.add_argument("--max-fill-edges", type=int, help="most consecutive dropped edges filled (64)")
    c.add_argument("--max-repairs", type=int, help="most repairs per channel (1000)")
    c.add_argument("--timing-resolution-s", type=float, metavar="S",
                   help="timing resolution of the edge times [s]; intervals within twice this of the reference are "
                        "never repaired (default 1/clock_hz, or the sample step)")
    c.add_argument("--edge-period", type=int, choices=(1, 2, 4),
                   help="compare edge intervals this many edges apart (4 for x4 decoding; default: the decoding)")
    if not scale:
        return
    c.add_argument("--ratio-tolerance", type=float, help="allowed relative mismatch of the speed ratio and z1/z2 "
                   "(default 0.005)")
    c.add_argument("--estimate-scale", choices=("none", "input", "output"),
                   help="estimate this encoder's counts per shaft revolution from the speed ratio and correct it")

#: ``[signal]`` key -> the option that overrides it (errors caused by an option name the option).
OPTION_KEYS = {"te_on": "--te-on", "lowpass_hz": "--lowpass-hz", "lowpass_order": "--lowpass-order",
               "highpass_hz": "--highpass-hz", "zero_phase": "--causal", "detrend": "--detrend",
               "grid_fs_hz": "--fs-hz", "rpm_tolerance": "--rpm-tolerance", "strict": "--strict",
               "edge_interp": "--edge-interp"}
#: The options of :func:`add_read_args` and the ``[signal]`` keys they override.
READ_OPTION_KEYS = {"t_start_s": "--t-start", "t_end_s": "--t-end", "trim": "--no-trim",
                    "min_speed_fraction": "--min-speed-fraction", "double_ratio": "--double-ratio",
                    "gap_ratio": "--gap-ratio", "integer_tol": "--integer-tol", "max_fill_edges": "--max-fill-edges",
                    "max_repairs": "--max-repairs", "timing_resolution_s": "--timing-resolution-s",
                    "edge_period": "--edge-period", "ratio_tolerance": "--ratio-tolerance",
                    "estimate_scale": "--estimate-scale"}
OPTION_KEYS.update(READ_OPTION_KEYS)


def read_overrides(args: argparse.Namespace) -> dict:
    """``[signal]`` overrides from the options of :func:`add_read_args` (None: not given)."""
    return {"t_start_s": args.t_start, "t_end_s": args.t_end, "trim": False if args.no_trim else None,
            "min_speed_fraction": args.min_speed_fraction, "double_ratio": args.double_ratio,
            "gap_ratio": args.gap_ratio, "integer_tol": args.integer_tol, "max_fill_edges": args.max_fill_edges,
            "max_repairs": args.max_repairs, "timing_resolution_s": args.timing_resolution_s,
            "edge_period": args.edge_period, "ratio_tolerance": getattr(args, "ratio_tolerance", None),
            "estimate_scale": getattr(args, "estimate_scale", None)}


MAX_RECORD_S = 3.2e7


def check_read_args(args: argparse.Namespace) -> None:
    """Ranges of the options of :func:`add_read_args` (one line naming the option)."""
    from gearrom.cli._args import option_error, check_number

    # a record of more than a year is no rig recording: the bound keeps a typo from passing silently
    check_number("--t-start", args.t_start, ge=0, le=MAX_RECORD_S, unit="s", key="t_start_s")
    check_number("--t-end", args.t_end, gt=0, le=MAX_RECORD_S, unit="s", key="t_end_s")
    if args.t_start is not None and args.t_end is not None and not args.t_end > args.t_start:
        raise option_error("--t-end", args.t_end, f"must be > --t-start={args.t_start!r}")
    check_number("--min-speed-fraction", args.min_speed_fraction, gt=0, le=0.99, key="min_speed_fraction")
    check_number("--double-ratio", args.double_ratio, gt=0, le=0.99, key="double_ratio")
    check_number("--gap-ratio", args.gap_ratio, gt=1, le=100, key="gap_ratio")
    check_number("--integer-tol", args.integer_tol, gt=0, le=0.49, key="integer_tol")
    check_number("--max-fill-edges", args.max_fill_edges, ge=0, le=10**6, integer=True, key="max_fill_edges")
    check_number("--max-repairs", args.max_repairs, ge=0, le=10**9, integer=True, key="max_repairs")
    check_number("--timing-resolution-s", args.timing_resolution_s, gt=0, le=1, unit="s", key="timing_resolution_s")
    check_number("--ratio-tolerance", getattr(args, "ratio_tolerance", None), gt=0, le=1, key="ratio_tolerance")
#: Highest grid rate accepted, Hz: above any encoder counter clock, so a finer grid resolves nothing.
FS_LIMIT_HZ = 1e9


def check_args(args: argparse.Namespace) -> None:
    """Check every option before anything is read or computed (one-line errors naming the option)."""
    from gearrom.cli._args import PLOT_SUFFIXES, check_number, check_output

    check_number("--lowpass-hz", args.lowpass_hz, gt=0, unit="Hz", key="lowpass_hz")
    check_number("--lowpass-order", args.lowpass_order, ge=1, le=12, integer=True, key="lowpass_order")
    check_number("--highpass-hz", args.highpass_hz, gt=0, unit="Hz", key="highpass_hz")
    check_number("--fs-hz", args.fs_hz, gt=0, le=FS_LIMIT_HZ, unit="Hz", key="grid_fs_hz")
    check_number("--rpm-tolerance", args.rpm_tolerance, gt=0, le=1, key="rpm_tolerance")
    check_read_args(args)
    args.json_out = check_output("--json", args.json_out, stdout=True, what="JSON file")
    args.plot = check_output("--plot", args.plot, PLOT_SUFFIXES, what="figure")
    args.save = check_output("--save", args.save, what="result file")


def _check_rates(args: argparse.Namespace, meta, read_settings, te_settings, config: str) -> None:
    """Grid rate and filter cut-offs against the record (metadata only, before the data are read)."""
    from gearrom.errors import ConfigError
    from gearrom.signal.angles import auto_fs

    def source(key: str, opt_value) -> str:
        return f"{OPTION_KEYS[key]}={opt_value!r}" if opt_value is not None else f"{config} [signal] {key}"

    if meta.kind == "angles":
        return
    fs = auto_fs(meta, read_settings)
    if meta.clock_hz is not None and fs > meta.clock_hz:
        raise ConfigError(f"{source('grid_fs_hz', args.fs_hz)}: grid rate {fs:g} Hz above the time-stamp clock "
                          f"clock_hz={meta.clock_hz:g} Hz of {meta.path}: a finer grid resolves nothing")
    f = te_settings.filters
    for key, fc, opt in (("lowpass_hz", f.lowpass_hz, args.lowpass_hz), ("highpass_hz", f.highpass_hz, args.highpass_hz)):
        if fc is not None and not fc < fs / 2:
            raise ConfigError(f"{source(key, opt)}: cut-off {fc:g} Hz must lie below the Nyquist frequency "
                              f"{fs / 2:g} Hz of the {fs:g} Hz time grid")


def run(args: argparse.Namespace) -> int:
    """Process the measurement and write the requested outputs.

    The options are checked first; the summary JSON, the most robust output, is written before the
    result file and the figure.
    """
    import dataclasses

    from gearrom.cli._args import prepare_output
    from gearrom.errors import ConfigError
    from gearrom.signal import compute_te, load_angles, read_meta
    from gearrom.signal.config import settings_from_config
    from gearrom.signal.te import DEFAULT_CONFIG, GearMeshInfo

    check_args(args)
    if args.config is not None:
        from gearrom.config import load_config

        try:
            load_config(args.config, check=False)
        except ConfigError as exc:
            raise ConfigError(f"--config={args.config!r}: {exc}") from None
    meta = read_meta(args.measurement)
    config = args.config or meta.config or DEFAULT_CONFIG
    overrides = {"te_on": args.te_on, "lowpass_hz": args.lowpass_hz, "lowpass_order": args.lowpass_order,
                 "highpass_hz": args.highpass_hz, "zero_phase": False if args.causal else None,
                 "detrend": args.detrend, "grid_fs_hz": args.fs_hz, "rpm_tolerance": args.rpm_tolerance,
                 "strict": True if args.strict else None, "edge_interp": args.edge_interp, **read_overrides(args)}
    te_settings, read_settings = settings_from_config(config, overrides, OPTION_KEYS)
    if args.allow_outside_data:
        read_settings = dataclasses.replace(read_settings, allow_outside_data=True)
    mesh = GearMeshInfo.from_config(config)
    _check_rates(args, meta, read_settings, te_settings, str(config))
    res = compute_te(load_angles(meta, read_settings), mesh, te_settings)
    summary = res.to_json_dict()
    text = json.dumps(summary, indent=2) + "\n"
    if args.json_out == "-":
        sys.stdout.write(text)
    elif args.json_out:
        prepare_output(args.json_out).write_text(text)
    if args.save:
        res.save(prepare_output(args.save))
    if args.json_out != "-":
        amp = ", ".join(f"{a:.3g}" for a in summary["gmf_amplitude_um"])
        sys.stdout.write(f"{args.measurement}: {summary['rpm_in']:.1f} rpm, TE ({summary['te_on']}) rms "
                         f"{summary['te_rms_um']:.3g} um, ptp {summary['te_ptp_um']:.3g} um, GMF "
                         f"{summary['gmf_hz']:.1f} Hz, harmonics 1-3: {amp} um, {len(summary['repairs'])} repair(s)\n")
        if not summary["speed"]["steady"]:
            sys.stdout.write(f"  {summary['speed']['statement']}\n")
        for cut in summary.get("trimmed", []):
            sys.stdout.write(f"  cut: channel {cut['channel']!r}, t={cut['t_from_s']:.6g}..{cut['t_to_s']:.6g} s "
                             f"({cut['edges']} edges): {cut['reason']}\n")
        for ch, q in summary.get("quadrature", {}).items():
            sys.stdout.write(f"  {ch}: sampled at {q['sample_rate_hz']:.6g} Hz, edges up to {q['edge_rate_max_hz']:.6g}"
                             f" Hz: timing resolution {q['timing_resolution_s']:.3g} s = "
                             f"{100 * q['resolution_of_edge_interval']:.3g} % of the shortest edge interval, "
                             f"{q['illegal_transitions']} illegal transition(s)\n")
        if "encoder_scale" in summary:
            sys.stdout.write(f"  encoder scale: {summary['encoder_scale']['detail']}\n")
        for rep in summary["repairs"]:
            sys.stdout.write(f"  repair: {rep['where']}, channel {rep['channel']!r}, t={rep['t_s']:.9g} s: "
                             f"{rep['kind']}: {rep['detail']}\n")
    if args.plot:
        fig = res.plot()
        fig.savefig(prepare_output(args.plot), dpi=120)
    return 0
