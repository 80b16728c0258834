"""Static consistency of the helical 3D explicit model with the 3D LTCA: direct static solves, penalty and mesh study.

Usage::

    python validation/run_static_gate_helical.py [--points 16] [--torques 60 120] [--layers 8]
        [--outline-mm 0.3] [--sag-um S] [--body-mm 2.5] [--sector RAD] [--penalties 0.1 0.3 1 3 inf]
        [--reference] [--no-solve]

``--reference`` takes the helical references' own stored mesh (``ringdown_helical.json``'s sizes); ``--no-solve``
analyses the angles stored so far (the angles are solved coarse to fine, so a study stopped half way holds a
uniform grid of half the density).

The explicit model is the helical references' kind (:func:`gearrom.fe.explicit.helicalpair.helical_pair_model`:
transverse Q4 outline on the generated profile extruded in twisted Hex8 layers, fully integrated, two-pass
node-to-facet penalty contact), with whole gear bodies to the bores unless ``--sector`` cuts each gear to
the sector a run of that input angle meets. Each point is a direct static solve of that model
(:meth:`gearrom.fe.explicit.static3d.StaticPair3D.points`) at input angle ``j P / n`` from the start
position, for every penalty scale on the same compliances (``inf``: hard contact, the penalty's limit), on
the contact geometry of the rigid placement (``--geometry-update``: each on its deformed geometry, the
explicit model's equilibrium). ``geometry_update_at_start`` gives, per penalty scale, the
start position's TE re-solved on the deformed geometry (the explicit model's equilibrium,
:meth:`~gearrom.fe.explicit.static3d.StaticPair3D.loaded_state`) beside the linear one.

The LTCA side is the quasi-static 3D FE table of the sweep (:func:`gearrom.validation.pair_rom.mesh_excitation`)
at the same torques. The limits and the verdict per penalty scale are
:func:`gearrom.validation.static_gate.static_gate`'s for helical pairs (mean TE and tangent stiffness
within 5 %).

Results: ``validation/static_gate_helical_<mesh tag>.json``; points already in the file are kept, so an
interrupted study resumes. The contact sees each flank facet with its sag restored (the flank between the
facet's corners, :func:`gearrom.fe.explicit.contact.facet_sags`); ``*_flatfacets.json`` hold the same study
with flat facets, whose chords lie up to about 1 um (0.3 mm outline) inside the flank: a load-independent
offset of the static TE that shrinks with the square of the outline size.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
import time
import warnings
from pathlib import Path

import numpy as np

from gearrom.config import load_config
from gearrom.fe.explicit.gearpair import GearPairSetup
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model
from gearrom.fe.explicit.static3d import StaticPair3D
from gearrom.fe.mesh2d import settings_from_section
from gearrom.validation.pair_rom import REFERENCE_SLICES, fe_start_mesh_phase, mesh_excitation, reference_settings
from gearrom.validation.static_gate import static_gate

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_static_gate_helical")
MODEL_PENALTY = 0.1   # the penalty scale the model is built with; every studied scale is solved from it
#: the contact's view of the flank facets, recorded in the results (``*_flatfacets.json``: the same study with
#: the facets taken flat, without their sag)
FACETS = "curved: each facet's sag restored from its neighbours (gearrom.fe.explicit.contact.facet_sags)"
FLAT_FACETS = "flat: the bilinear facets' chords"


def _tag(layers: int, outline: float, body: float, sector: float | None, sag: float | None = None,
         periodic: bool = False) -> str:
    tag = (f"layers{layers}_outline{outline * 1e3:g}mm" + (f"_sag{sag * 1e6:g}um" if sag else "")
           + f"_body{body * 1e3:g}mm")
    return tag + (f"_sector{sector:g}rad" if sector is not None else "_full") + ("_periodic" if periodic else "")


def _steps(n: int) -> list[int]:
    """Angle steps of the coarse-to-fine grids of ``n`` angles: n, n // 2, n // 4, ..., 1."""
    steps = [n]
    while steps[-1] > 1:
        steps.append(steps[-1] // 2)
    return steps


def _coarseness(j: int, n: int) -> int:
    """Rank of angle ``j`` of ``n`` in a coarse-to-fine order: 0 for j = 0, then 1 for the grid of 2 angles,
    2 for the added angles of the grid of 4, and so on (the first of :func:`_steps` that ``j`` is on)."""
    return next(i for i, s in enumerate(_steps(n)) if j % s == 0)


def main(n: int = 16, torques=(60.0, 120.0), layers: int = 8, outline: float = 0.3e-3, body: float = 2.5e-3,
         grading: float = 1.0e-3, sector: float | None = None, penalties=(0.1, 0.3, 1.0, 3.0, math.inf),
         sag: float | None = None, geometry_update: bool = False, start_update: bool = True,
         flat_facets_record: bool = False, periodic: bool = False, reference: bool = False,
         solve: bool = True) -> Path:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # the seed pair's tip-fillet interference warning (see helicalpair)
        pair = load_config("thesis-helical").pair
    period = 2 * math.pi / pair.z[0]
    if reference:       # the references' own mesh: the sizes of the ring-down calibration, its stored meshes
        from run_ringdown import calibration

        ref = calibration("helical")["mesh"]
        layers, outline, body, grading = ref["n_layers"], ref["outline_size_m"], ref["body_size_m"], ref["grading_m"]
        sag, periodic, sector = ref["sag_m"], bool(ref.get("periodic", False)), None
    out = HERE / (f"static_gate_helical_{_tag(layers, outline, body, sector, sag, periodic)}"
                  + ("_reference" if reference else "") + ("_updated" if geometry_update else "") + ".json")
    data = json.loads(out.read_text()) if out.is_file() else {}
    if not flat_facets_record and data and data.get("facets") != FACETS:
        raise SystemExit(f"{out} holds points of flat contact facets (no sag restored): rename it to "
                         f"{out.stem}_flatfacets.json or delete it")
    if data.get("n_points", n) != n:
        raise SystemExit(f"{out} holds points of {data['n_points']} angles per mesh period, not {n}: use "
                         f"--points {data['n_points']} or another file")
    pts = data.setdefault("points", {})
    keys = [f"{p:g}" for p in penalties]
    data.update(config="thesis-helical", integration="full", n_layers=layers, outline_size_mm=outline * 1e3,
                body_size_mm=body * 1e3, grading_mm=grading * 1e3, sector_rad=sector, n_points=n, periodic=periodic,
                reference_meshes=reference,
                outline_sag_um=None if sag is None else sag * 1e6, geometry_update=geometry_update,
                solver="direct static solve of the explicit model (gearrom.fe.explicit.static3d)",
                definition="static TE on the transverse line of action (explicit runs' convention: zero at rigid "
                           "first contact of the start position) at input angle j * mesh_period / n_points, "
                           "per contact penalty scale (inf: hard contact)")
    data.setdefault("facets", FLAT_FACETS if flat_facets_record else FACETS)
    # coarse to fine (0, n/2, n/4, 3n/4, ...): a study stopped half way holds every other angle, a uniform
    # grid of half the density whose orders can be read already
    def solved(j: int) -> bool:
        return all(f"{k}/{t:g}" in pts.get(str(j), {}) for k in keys for t in torques)

    todo = sorted((j for j in range(n) if not solved(j)), key=lambda j: (_coarseness(j, n), j))
    upd = data.setdefault("geometry_update_at_start", {})
    upd_todo = [k for k in keys if k not in upd] if start_update else []
    if not solve:       # analyse the stored angles only
        todo, upd_todo = [], []
    if todo or upd_todo:
        t0 = time.perf_counter()
        if reference:
            from run_ringdown import reference_meshes

            meshes = reference_meshes(pair, ref)
        else:
            meshes = helical_meshes(pair, outline, body, grading, sag=sag, periodic=periodic)
        setup = GearPairSetup(rpm_in=1e-4, torque_out=max(torques), penalty_scale=MODEL_PENALTY, integration="full")
        model, info = helical_pair_model(pair, meshes, setup, layers, run_angle=sector)
        sp3 = StaticPair3D(model, info, pair)
        data.update(n_nodes=int(model.nodes.shape[0]), n_elements=int(model.elements.shape[0]),
                    n_free_dofs=[s.n_dofs for s in sp3.stiffness], twist_sag_um=info["twist_sag_m"] * 1e6,
                    layer_mm=info["layer_m"] * 1e3, model_build_s=time.perf_counter() - t0)
        for j in todo:
            t1 = time.perf_counter()
            res = sp3.points([j * period / n], torques, penalties, geometry_update)
            pts[str(j)] = {f"{p.penalty_scale:g}/{p.torque:g}": p.te * 1e6 for p in res}
            pts[str(j)]["n_loaded"] = {f"{p.penalty_scale:g}/{p.torque:g}": p.n_loaded for p in res}
            pts[str(j)]["solve_s"] = time.perf_counter() - t1
            out.write_text(json.dumps(data, indent=2, default=float) + "\n")
            log.info("point %d/%d done in %.0f s", j + 1, n, time.perf_counter() - t1)
        # the points solve on the rigid placement's contact geometry; at the start position the state is also
        # re-solved on the deformed geometry (as the explicit contact acts), at the highest torque
        for k, p in zip(keys, penalties):
            if k in upd or not start_update:
                continue
            _, _, te_upd = sp3.loaded_state(max(torques), p)
            upd[k] = {"torque_Nm": max(torques), "te_linear_um": pts["0"][f"{k}/{max(torques):g}"],
                      "te_updated_um": te_upd * 1e6}
            out.write_text(json.dumps(data, indent=2, default=float) + "\n")
    # the densest uniform grid of the solve order whose angles are all solved (all of them once complete)
    step = next((s for s in reversed(_steps(n)) if n % s == 0 and all(solved(j) for j in range(0, n, s))), None)
    if step is None:
        raise SystemExit(f"{out}: not even the start angle is solved; run without --no-solve")
    grid = list(range(0, n, step))
    m = len(grid)
    phase0 = fe_start_mesh_phase(pair)
    th = np.asarray(grid) * period / n
    lt, rom = {}, {}
    # the validation ROM's table: load-dependent, the reference strips and flank grid (gearrom validate)
    cfg = load_config("thesis-helical")
    fe_settings, _ = settings_from_section(cfg.section("fe"), cfg.name)
    ex_rom, rom_label = mesh_excitation(pair, max(torques), "fe", config_name=cfg.name, torque_map=True,
                                        settings=reference_settings(pair, fe_settings), n_slices=REFERENCE_SLICES)
    for t in torques:
        ex, label = mesh_excitation(pair, t, "fe")
        lt[t] = np.asarray(ex.ste(np.mod(phase0 + th, period), t), float)
        rom[t] = np.asarray(ex_rom.ste(np.mod(phase0 + th, period), t), float)
        data.setdefault("ltca_um", {})[f"{t:g}"] = (lt[t] * 1e6).tolist()
        data.setdefault("rom_table_um", {})[f"{t:g}"] = (rom[t] * 1e6).tolist()
        data["ltca_table"], data["rom_table"] = label, rom_label
    data["analysed_points"] = grid
    gates = {}
    for k in keys if m >= 8 else ():     # the gate's curve metrics need 8 angles or more
        fe = {t: np.array([pts[str(j)][f"{k}/{t:g}"] * 1e-6 for j in grid]) for t in torques}
        gates[k] = static_gate(fe, lt, pair.rb[1], helical=True)
        log.info("penalty %s (%d of %d angles): mean TE %s um against LTCA %s um; %s %s", k, m, n,
                 [round(float(fe[t].mean() * 1e6), 3) for t in torques],
                 [round(float(lt[t].mean() * 1e6), 3) for t in torques],
                 "pass" if gates[k]["passed"] else "FAIL", gates[k]["misses"])
    data["gate_by_penalty"] = gates

    # mesh orders the analysed angles resolve without aliasing (below m / 2): the layers' passing shows near
    # order n_layers / eps_beta
    def orders(x):
        x = np.asarray(x, float)
        return (np.abs(np.fft.rfft(x - x.mean()))[1:(m + 1) // 2] * 2 / m * 1e9).round(3).tolist()

    data["order_amplitudes_nm"] = {
        "explicit": {k: {f"{t:g}": orders([pts[str(j)][f"{k}/{t:g}"] * 1e-6 for j in grid]) for t in torques}
                     for k in keys},
        "ltca": {f"{t:g}": orders(lt[t]) for t in torques}, "rom_table": {f"{t:g}": orders(rom[t]) for t in torques},
        "n_angles": m}
    t_op = min(torques, key=lambda t: abs(t - 120.0))      # the references' operating torque
    for k in keys:
        log.info("penalty %s, orders 1-%d at %g N m: explicit %s nm, validation ROM table %s nm", k, (m - 1) // 2,
                 t_op, data["order_amplitudes_nm"]["explicit"][k][f"{t_op:g}"],
                 data["order_amplitudes_nm"]["rom_table"][f"{t_op:g}"])
    data["machine"] = {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_average": os.getloadavg()}
    out.write_text(json.dumps(data, indent=2, default=float) + "\n")
    return out


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=16)
    ap.add_argument("--torques", type=float, nargs="+", default=[60.0, 120.0])
    ap.add_argument("--layers", type=int, default=8)
    ap.add_argument("--outline-mm", type=float, default=0.3)
    ap.add_argument("--body-mm", type=float, default=2.5)
    ap.add_argument("--sector", type=float, default=None, help="cut each gear to the sector a run of this input "
                    "angle (rad) meets; default: whole bodies")
    ap.add_argument("--penalties", type=float, nargs="+", default=[0.1, 0.3, 1.0, 3.0, math.inf])
    ap.add_argument("--sag-um", type=float, default=None, help="refine the flank outline to chords within this "
                    "of the profile, um")
    ap.add_argument("--no-start-update", action="store_true", help="skip the start position's re-solve on the "
                    "deformed geometry (geometry_update_at_start)")
    ap.add_argument("--geometry-update", action="store_true", help="solve every point on its deformed contact "
                    "geometry (the explicit model's equilibrium; about 3 times the time); writes *_updated.json")
    ap.add_argument("--periodic", action="store_true", help="tooth-periodic sections (the reference mesh kind); "
                    "writes *_periodic.json")
    ap.add_argument("--no-solve", action="store_true", help="analyse the angles already stored (the densest "
                    "complete uniform grid of them), solve nothing")
    ap.add_argument("--reference", action="store_true", help="the helical references' own mesh (sizes of "
                    "ringdown_helical.json, its stored meshes; overrides the mesh options); writes *_reference.json")
    a = ap.parse_args()
    main(a.points, tuple(a.torques), a.layers, a.outline_mm * 1e-3, a.body_mm * 1e-3, sector=a.sector,
         penalties=tuple(a.penalties), sag=None if a.sag_um is None else a.sag_um * 1e-6,
         geometry_update=a.geometry_update, start_update=not a.no_start_update, periodic=a.periodic,
         reference=a.reference, solve=not a.no_solve)
