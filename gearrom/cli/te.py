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
    g.add_argument("--detrend", choices=("linear", "constant", "none"),
                   help="trend removed before filtering (default linear: offset and nominal slope)")
    r = parser.add_argument_group("reader")
    r.add_argument("--fs-hz", type=float, help="rate of the common time grid [Hz] (default: from the edge rate)")
    r.add_argument("--rpm-tolerance", type=float, help="allowed relative mismatch of rpm_in and the data (default 0.05)")
    r.add_argument("--strict", action="store_true", help="fail on anything that would need a repair")
    r.add_argument("--edge-interp", choices=("cubic", "linear"), help="angle between encoder edges (default cubic)")


def run(args: argparse.Namespace) -> int:
    """Process the measurement and write the requested outputs."""
    from gearrom.signal import compute_te, load_angles, read_meta
    from gearrom.signal.config import settings_from_config
    from gearrom.signal.te import DEFAULT_CONFIG, GearMeshInfo

    meta = read_meta(args.measurement)
    config = args.config or meta.config or DEFAULT_CONFIG
    overrides = {"te_on": args.te_on, "lowpass_hz": args.lowpass_hz, "lowpass_order": args.lowpass_order,
                 "highpass_hz": args.highpass_hz, "zero_phase": False if args.causal else None,
                 "detrend": args.detrend, "grid_fs_hz": args.fs_hz, "rpm_tolerance": args.rpm_tolerance,
                 "strict": True if args.strict else None, "edge_interp": args.edge_interp}
    te_settings, read_settings = settings_from_config(config, overrides)
    res = compute_te(load_angles(meta, read_settings), GearMeshInfo.from_config(config), te_settings)
    summary = res.to_json_dict()
    text = json.dumps(summary, indent=2) + "\n"
    if args.json_out == "-":
        sys.stdout.write(text)
    else:
        if args.json_out:
            Path(args.json_out).write_text(text)
        amp = ", ".join(f"{a:.3g}" for a in summary["gmf_amplitude_um"])
        sys.stdout.write(f"{args.measurement}: {summary['rpm_in']:.1f} rpm, TE ({summary['te_on']}) rms "
                         f"{summary['te_rms_um']:.3g} um, ptp {summary['te_ptp_um']:.3g} um, GMF "
                         f"{summary['gmf_hz']:.1f} Hz, harmonics 1-3: {amp} um, {len(summary['repairs'])} repair(s)\n")
        for rep in summary["repairs"]:
            sys.stdout.write(f"  repair: {rep['where']}, channel {rep['channel']!r}, t={rep['t_s']:.9g} s: "
                             f"{rep['kind']}: {rep['detail']}\n")
    if args.plot:
        res.plot().savefig(args.plot, dpi=120)
    if args.save:
        res.save(args.save)
    return 0
