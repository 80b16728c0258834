"""``gearrom stiffness``: quasi-static FE mesh stiffness, static TE and load sharing over a mesh cycle."""
from __future__ import annotations

import json
import logging
import sys
from pathlib import Path

from gearrom.errors import ConfigError

NAME = "stiffness"
HELP = "FE loaded tooth contact analysis: static TE, mesh stiffness and load sharing over a mesh cycle"

log = logging.getLogger(__name__)


def add_args(parser) -> None:
    parser.add_argument("config", metavar="NAME_OR_PATH", help="bundled config name or TOML file")
    parser.add_argument("--torque-Nm", dest="torque", type=float, nargs="+", metavar="T",
                        help="output torque(s) [N m] (default: fe.torques_Nm, else operating.torque_out_Nm)")
    parser.add_argument("--positions", type=int, default=None, help="mesh positions per cycle (default 64)")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the results as JSON")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="plot STE, stiffness, load share, pressure")
    parser.add_argument("--pattern", type=Path, metavar="PNG",
                        help="helical pairs: plot the contact pattern over the mesh cycle (first torque)")
    parser.add_argument("--save", type=Path, metavar="NC", help="write the MeshExcitation table (NetCDF)")
    parser.add_argument("--vtu", type=Path, metavar="VTU", help="write the loaded state at theta = 0 (first torque) for ParaView")
    parser.add_argument("--inp", type=Path, metavar="INP",
                        help="write the Abaqus/CalculiX deck at theta = 0 (first torque); solve it with "
                             "'ccx -i STEM' and read the static TE with 'gearrom ccx-te INP'")
    parser.add_argument("--inp-mesh", choices=("deck", "analysis"), default="deck",
                        help="mesh of the spur deck: 'deck' (coarser, ccx solves it in minutes; default) or "
                             "'analysis' (the LTCA's own mesh); helical decks use the 3D LTCA mesh")
    parser.add_argument("--mesh-factor", type=float, default=1.0, help="scale all mesh sizes (refinement studies)")
    parser.add_argument("--helical-model", choices=("3d", "slices"), default="3d",
                        help="helical pairs: 3D FE compliances (default) or uncoupled plane-strain slices")
    parser.add_argument("--no-cache", action="store_true", help="do not read or write the FE cache")
    parser.add_argument("--cache-dir", help="FE cache directory (default $GEARROM_CACHE_DIR/fe or ~/.cache/gearrom/fe)")


def check_args(args) -> None:
    """Check the options before the FE model is built (one-line errors naming the option)."""
    from gearrom.cli._args import PLOT_SUFFIXES, check_number, check_output, check_output_dir

    for t in args.torque or ():
        check_number("--torque-Nm", t, gt=0, le=1e7, unit="N m")
    check_number("--positions", args.positions, ge=4, le=4096, integer=True)
    # below 0.1 the meshes outgrow memory and hours of solving; above 10 nothing of a tooth is left
    check_number("--mesh-factor", args.mesh_factor, ge=0.1, le=10)
    for opt, dest, suffixes in (("--json", "json", None), ("--plot", "plot", PLOT_SUFFIXES),
                                ("--pattern", "pattern", PLOT_SUFFIXES), ("--save", "save", None),
                                ("--vtu", "vtu", None), ("--inp", "inp", None)):
        setattr(args, dest, check_output(opt, getattr(args, dest), suffixes))
    args.cache_dir = check_output_dir("--cache-dir", args.cache_dir)


def run(args) -> int:
    from gearrom.config import load_config
    from gearrom.fe.iso6336 import mesh_stiffness
    from gearrom.fe.mesh2d import settings_from_section
    from gearrom.fe.sweep import build_ltca, mesh_cycle

    check_args(args)
    cfg = load_config(args.config)
    settings, extra = settings_from_section(cfg.section("fe"), str(cfg.source or cfg.name))
    if args.mesh_factor <= 0:
        raise ConfigError(f"--mesh-factor must be positive, got {args.mesh_factor}")
    settings = settings.scaled(args.mesh_factor) if args.mesh_factor != 1.0 else settings
    torques = args.torque or extra.get("torques_Nm") or [cfg.operating.torque_out]
    if any(not (t > 0) for t in torques):
        raise ConfigError(f"--torque-Nm values must be positive, got {torques}")
    n = args.positions or int(extra.get("positions", 64))
    if n < 4:
        raise ConfigError(f"--positions must be >= 4, got {n}")
    if args.pattern and not cfg.pair.is_helical:
        raise ConfigError(f"--pattern: {cfg.name} is a spur pair; the contact pattern over face width x profile is "
                          "computed for helical pairs only")
    cache = False if args.no_cache else (args.cache_dir or True)
    settings3d = None
    if cfg.pair.is_helical and args.helical_model == "3d" and args.mesh_factor != 1.0:
        from gearrom.fe.mesh3d import Mesh3DSettings

        settings3d = Mesh3DSettings().scaled(args.mesh_factor)
    ltca = build_ltca(cfg.pair, settings, cache, helical_model=args.helical_model, settings3d=settings3d)
    res = mesh_cycle(ltca, torques, n, metadata={"config": cfg.name, "config_digest": cfg.digest()})
    iso = mesh_stiffness(cfg.pair) * cfg.pair.face_width
    j0 = int(abs(res.torque - float(torques[0])).argmin())  # the first torque given leads the JSON
    out = res.summary(j0)
    out["config"] = cfg.name
    out["iso6336_c_gamma_alpha_N_per_um"] = iso * 1e-6
    out["ratio_to_iso6336"] = out["mean_stiffness_N_per_um"] / (iso * 1e-6)
    out["by_torque"] = [{k: v for k, v in res.summary(j).items() if k != "definition"} for j in range(res.torque.size)]
    for j in range(res.torque.size):
        s = res.summary(j)
        sys.stdout.write(
            f"{cfg.name} @ {s['torque_Nm']:.4g} N m: mean k {s['mean_stiffness_N_per_um']:.1f} N/um "
            f"(ptp {s['stiffness_ptp_N_per_um']:.1f}), STE mean {s['ste_mean_um']:.3f} um ptp {s['ste_ptp_um']:.3f} um, "
            f"max pressure {s['max_contact_pressure_MPa']:.0f} MPa\n")
    sys.stdout.write(f"definition: {res.definition}\nISO 6336 c_gamma_alpha b = {iso * 1e-6:.1f} N/um "
                     f"(FE/ISO = {out['ratio_to_iso6336']:.3f} at {res.torque[j0]:.4g} N m)\n")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1))
    if args.plot:
        args.plot.parent.mkdir(parents=True, exist_ok=True)
        res.plot().savefig(args.plot, dpi=120)
    if args.pattern:
        args.pattern.parent.mkdir(parents=True, exist_ok=True)
        res.plot_pattern(j0).savefig(args.pattern, dpi=120)
    if args.save:
        args.save.parent.mkdir(parents=True, exist_ok=True)
        res.to_excitation().save(args.save)
    if args.vtu or args.inp:
        from gearrom.fe.export import export_inp, export_vtu

        if args.vtu:
            export_vtu(ltca, 0.0, float(torques[0]), args.vtu, settings)
        if args.inp:
            t0 = float(torques[0])
            deck_settings = settings if args.inp_mesh == "analysis" and not cfg.pair.is_helical else None
            info = export_inp(cfg.pair, 0.0, t0, args.inp, deck_settings, mesh_factor=args.mesh_factor,
                              ltca_ste=ltca.solve(0.0, t0).ste)
            sys.stdout.write(f"deck {info.path}: {info.nodes} nodes, {info.elements} elements; solve with "
                             f"'ccx -i {info.path.with_suffix('')}', then 'gearrom ccx-te {info.path}'\n")
    return 0
