"""Why the pair ROM's mesh mode lies below the explicit FE's: the gear bodies' torsional flexibility.

Usage: ``python validation/run_mesh_mode.py [--pair spur|helical] [--torque 120] [--modes 12]``.

The validation ROM (:mod:`gearrom.validation.pair_rom`) is one rotational DOF: the output gear, rigid, with the
polar inertia of the FE's output-gear mesh, on the LTCA table's mesh stiffness (bore-clamped gears: contact,
tooth bending and the bodies' torsion in series), the input bore held. The explicit FE's ring-down
(``validation/ringdown_spur.json``, input held, output free) measures its mesh mode directly. The two differ
by more than the table's error, and the candidate is the body: in the FE, the rim and teeth of each gear swing
on the body's torsional compliance, so the output hub moves less than the rim and the input rim moves though
the input bore is held.

This script computes, from the same gear meshes as the reference model (Q4, plane strain times the face
width, steel of :class:`gearrom.fe.explicit.model.Material`):

1. each gear's bore-clamped torsional modes (:mod:`gearrom.fe.bodies`: scikit-fem, consistent mass) with the
   effective inertia of each about the axis, ``J_j = (phi_j^T M r)^2`` for mass-normalised ``phi_j`` and the
   rigid rotation field ``r``
   (``sum_j J_j`` over all modes is the gear's inertia without the bore);
2. a body model of each gear: its first torsional mode as a rim of inertia ``J_r`` on a torsional spring
   ``k_b = J_r w_b^2`` to the hub (the bore), the rest of the inertia on the hub;
3. the mesh mode of the ROM's 1-DOF model and of the model with the bodies (input rim on the held bore,
   the mesh spring with the bodies' compliance taken out of the table's, output rim on the output hub),
   against the ring-down's frequency.

It writes ``validation/mesh_mode_<pair>.json``. The table is the validation ROM's (load-dependent LTCA table
on the reference flank grid or strips, as ``gearrom validate`` builds it); its tangent stiffness is taken over
the mesh cycle at ``--torque`` and at the ring-down's position and stepped torque, and the latter scaled to the
explicit model's own static stiffness (its static consistency study, :data:`STATIC_GATE`: the table and the
explicit model differ by the gate's stiffness error, which moves the mode by half of it). The helical bodies come
from the reference model's transverse mesh times the face width (the model extrudes it in twisted layers;
the body's torsion is that of the prismatic disc).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_mesh_mode")


def mesh_modes(k_table: float, rb: tuple[float, float], J_out: float, bodies: list[dict] | None) -> float:
    """The mesh mode [Hz] of the input-held pair: 1-DOF (``bodies`` None) or with the body models.

    ``k_table``: the table's tangent mesh stiffness on the line of action, N/m (bodies included, bore-clamped);
    ``J_out``: the output gear's inertia, kg m^2. With bodies, the DOFs are the input rim, the output rim and
    the output hub (rotations), the mesh spring acts on rb1 theta_1r - rb2 theta_2r and carries the table's
    compliance less both bodies' (on the line of action: 1 / (k_b / rb^2))."""
    rb1, rb2 = rb
    if bodies is None:
        return float(np.sqrt(k_table * rb2 ** 2 / J_out) / (2 * np.pi))
    b1, b2 = bodies
    c_mesh = 1.0 / k_table - rb1 ** 2 / b1["k_body_Nm_per_rad"] - rb2 ** 2 / b2["k_body_Nm_per_rad"]
    if c_mesh <= 0:
        raise ValueError("the bodies' torsional compliance exceeds the table's: the body model does not apply")
    km, kb1, kb2 = 1.0 / c_mesh, b1["k_body_Nm_per_rad"], b2["k_body_Nm_per_rad"]
    # DOFs: theta_1r, theta_2r, theta_2h; mesh deflection rb1 t1r - rb2 t2r (sign irrelevant for the modes)
    K = np.array([[kb1 + km * rb1 ** 2, -km * rb1 * rb2, 0.0],
                  [-km * rb1 * rb2, km * rb2 ** 2 + kb2, -kb2],
                  [0.0, -kb2, kb2]])
    Jh2 = J_out - b2["J_rim_kgm2"]
    M = np.diag([b1["J_rim_kgm2"], b2["J_rim_kgm2"], Jh2])
    from scipy.linalg import eigh

    w2 = eigh(K, M, eigvals_only=True)
    return float(np.sqrt(w2[0]) / (2 * np.pi))


def mesh_mode_static_bodies(k_table: float, rb: tuple[float, float], modes: list[dict]) -> float:
    """The mesh mode [Hz] of the input-held pair with each body as its static mode (Rayleigh-Ritz on the rigid
    rotation and the deflection under the inertia load, :func:`gearrom.fe.bodies.torsional_modes`): DOFs the
    input's elastic rotation q1, the output hub theta_2h and its elastic rotation q2; the mesh spring on
    rb1 q1 - rb2 (theta_2h + q2) with the table's compliance less both bodies' static-mode compliance."""
    from scipy.linalg import eigh

    rb1, rb2 = rb
    kb1, kb2 = (m["static_mode"]["k_body_Nm_per_rad"] for m in modes)
    c_mesh = 1.0 / k_table - rb1 ** 2 / kb1 - rb2 ** 2 / kb2
    if c_mesh <= 0:
        raise ValueError("the bodies' torsional compliance exceeds the table's: the body model does not apply")
    a = np.array([rb1, -rb2, -rb2])
    K = np.outer(a, a) / c_mesh + np.diag([kb1, 0.0, kb2])
    m1, m2 = modes
    M = np.array([[m1["static_mode"]["M_qq_kgm2"], 0.0, 0.0],
                  [0.0, m2["inertia_kgm2"], m2["inertia_without_bore_kgm2"]],
                  [0.0, m2["inertia_without_bore_kgm2"], m2["static_mode"]["M_qq_kgm2"]]])
    return float(np.sqrt(eigh(K, M, eigvals_only=True)[0]) / (2 * np.pi))


def model_inertias(pair, meshes, mesh: dict) -> tuple[float, float]:
    """Polar inertias [kg m^2] of the two gears of the reference explicit model with the nodal masses it runs
    with (mass scaling to its step included)."""
    from run_ringdown import reference_model, reference_setup

    from gearrom.fe.explicit import prepare
    from gearrom.fe.explicit.gearpair import polar_inertias

    model, info = reference_model(pair, meshes, reference_setup(mesh, rpm_in=2000.0, torque_out=120.0, mu=0.0), mesh)
    d = prepare(model, 0.9, mesh.get("max_candidates"))
    return polar_inertias(model, d["mass"], info.get("n_nodes_gear1", info["n_gear1"]))


#: the static consistency studies of the reference meshes (explicit model against the validation table)
STATIC_GATE = {"spur": "static_gate_spur_sag0.25um_penalty1_body0.75mm_periodic.json",
               "helical": "static_gate_helical_layers16_outline0.15mm_sag1um_body2.5mm_full_periodic_reference.json"}


def static_stiffness_ratio(kind: str, mesh: dict) -> float:
    """The explicit reference model's static tangent mesh stiffness over the validation table's, from its static
    consistency study (:data:`STATIC_GATE`; the helical study at the reference's contact penalty)."""
    d = json.loads((HERE / STATIC_GATE[kind]).read_text())
    gate = d["gate"] if "gate" in d else d["gate_by_penalty"][f"{mesh['penalty_scale']:g}"]
    k = gate["stiffness_N_per_um"]
    return float(k["fe"] / k["ltca"])


def table_tangent(pair, torque: float, torque_at: float, theta0: float) -> dict:
    """Tangent mesh stiffness [N/m] of the validation ROM's table (load-dependent, as ``gearrom validate`` builds
    it: :func:`gearrom.validation.pair_rom.mesh_excitation` on the reference flank grid / strips) at ``torque``,
    averaged over the mesh cycle, and at ``torque_at`` at the mesh phase ``theta0``."""
    from gearrom.config import load_config
    from gearrom.fe.mesh2d import settings_from_section
    from gearrom.rom.mesh import ForceMap
    from gearrom.validation.pair_rom import REFERENCE_SLICES, mesh_excitation, reference_settings

    cfg = load_config(CONFIG[PAIR_KIND[pair.is_helical]])
    fe_settings, _ = settings_from_section(cfg.section("fe"), cfg.name)
    ex, label = mesh_excitation(pair, torque, "fe", config_name=cfg.name, torque_map=True,
                                settings=reference_settings(pair, fe_settings), n_slices=REFERENCE_SLICES)
    fmap = ForceMap.from_table(ex, pair.rb[1], torque)
    period = 2 * np.pi / pair.z[0]
    return {"mean over the mesh cycle": float(fmap.tangent(torque / pair.rb[1]).mean()),
            "ring-down position and torque": float(np.interp(theta0, fmap.theta, fmap.tangent(torque_at / pair.rb[1]),
                                                             period=period)),
            "table": label}


#: the pair of each kind and its bundled config
PAIR_KIND = {False: "spur", True: "helical"}
CONFIG = {"spur": "thesis-spur", "helical": "thesis-helical"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pair", choices=sorted(CONFIG), default="spur")
    ap.add_argument("--torque", type=float, default=120.0, help="output torque, N m")
    ap.add_argument("--modes", type=int, default=12, help="bore-clamped modes per gear")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    sys.path.insert(0, str(HERE))
    from run_ringdown import REFERENCE, calibration, reference_meshes

    from gearrom.config import load_config
    from gearrom.fe.bodies import body_from_modes, torsional_modes
    from gearrom.validation.pair_rom import fe_start_mesh_phase, polar_inertia

    pair = load_config(CONFIG[args.pair]).pair
    mesh = REFERENCE[args.pair]
    if pair.is_helical:      # the stored transverse meshes the helical references run on
        meshes = reference_meshes(pair, mesh)
    else:                    # the spur references' sizes, meshed here (no stored mesh file is written for them)
        from gearrom.fe.explicit.gearmesh import gear_quad_mesh

        meshes = [gear_quad_mesh(pair, i, mesh["outline_size_m"], mesh["body_size_m"], sag=mesh["sag_m"],
                                 periodic=mesh.get("periodic", False)) for i in (0, 1)]
    width = pair.face_width
    bodies, modes = [], []
    for i, (nodes, quads, bore) in enumerate(meshes[:2]):
        m = torsional_modes(nodes, quads, bore, width, n_modes=args.modes)
        m["inertia_exact_kgm2"] = polar_inertia(nodes, quads, (0.0, 0.0), 7850.0, width)
        modes.append(m)
        body = body_from_modes(m)
        bodies.append({"mode_frequency_Hz": body.frequency, "J_rim_kgm2": body.rim_inertia,
                       "J_hub_kgm2": body.hub_inertia, "k_body_Nm_per_rad": body.stiffness,
                       "rim_share_of_inertia": body.rim_inertia / body.inertia})
        log.info("gear %d: first torsional body mode %.0f Hz, rim %.1f %% of the inertia", i, body.frequency,
                 100 * body.rim_inertia / body.inertia)
    cal = calibration(args.pair)
    inertia_note = "the meshes' polar inertias"
    if mesh.get("mass_scaling_dt_s") and args.pair == "helical":
        # the reference model's mass scaling adds inertia on its small elements (the rims' tip roundings):
        # the gears take the model's own polar inertias, the bodies scaled to them (same rim share)
        j_model = model_inertias(pair, meshes, mesh)
        for i, m in enumerate(modes):
            scaled = body_from_modes(m).with_inertia(j_model[i])
            bodies[i] = {"mode_frequency_Hz": scaled.frequency, "J_rim_kgm2": scaled.rim_inertia,
                         "J_hub_kgm2": scaled.hub_inertia, "k_body_Nm_per_rad": scaled.stiffness,
                         "rim_share_of_inertia": scaled.rim_inertia / scaled.inertia}
            s = j_model[i] / m["inertia_kgm2"]
            m["inertia_exact_kgm2"] = j_model[i]
            m["static_mode"] = {"k_body_Nm_per_rad": m["static_mode"]["k_body_Nm_per_rad"],
                                "M_qq_kgm2": m["static_mode"]["M_qq_kgm2"] * s}
            m["inertia_without_bore_kgm2"] *= s
            m["inertia_kgm2"] = j_model[i]
        inertia_note = "the reference model's polar inertias (mass scaling included; the bodies' masses scaled alike)"
    f_fe = float(cal["runs"][-1]["frequency_Hz"])
    zeta = float(cal["zeta_measured"])
    f_fe_undamped = f_fe / np.sqrt(1 - zeta ** 2)
    T = args.torque
    T_ring = float(cal["torque_step_Nm"][1])       # the ring-down oscillates about the stepped torque's state
    theta0 = fe_start_mesh_phase(pair)             # the ring-down holds the input at the FE's start position
    k_at = table_tangent(pair, T, T_ring, theta0)
    label = k_at.pop("table")
    ratio = static_stiffness_ratio(args.pair, mesh)
    k_at["ring-down position and torque, table at the explicit model's static stiffness"] = (
        k_at["ring-down position and torque"] * ratio)
    J_out = modes[1]["inertia_exact_kgm2"]
    cases = {}
    for name, k_table in k_at.items():
        f = {"rom_1dof": mesh_modes(k_table, pair.rb, J_out, None),
             "rom_with_bodies": mesh_modes(k_table, pair.rb, J_out, bodies),
             "rom_with_static_mode_bodies": mesh_mode_static_bodies(k_table, pair.rb, modes)}
        cases[name] = {"table_tangent_stiffness_N_per_um": k_table * 1e-6, "mesh_mode_Hz": f,
                       "difference_to_fe": {k: v / f_fe_undamped - 1 for k, v in f.items()}}
        log.info("%s: k_t %.1f N/um; mesh mode: 1-DOF ROM %.0f Hz, with bodies %.0f Hz (first mode) / %.0f Hz "
                 "(static mode), FE ring-down %.0f Hz", name, k_table * 1e-6, f["rom_1dof"], f["rom_with_bodies"],
                 f["rom_with_static_mode_bodies"], f_fe_undamped)
    out = {
        "pair": CONFIG[args.pair], "torque_out_Nm": T, "ringdown_torque_Nm": T_ring, "mesh": mesh, "table": label,
        "ringdown_mesh_phase_rad": theta0, "static_stiffness_ratio_fe_to_ltca": ratio,
        "static_gate": STATIC_GATE[args.pair], "output_inertia_kgm2": J_out, "fe_ringdown_undamped_Hz": f_fe_undamped,
        "gears": [{"modes": m, "body_model": b} for m, b in zip(modes, bodies)],
        "cases": cases,
        "inertias": inertia_note,
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform()},
        "note": "fe_ringdown_undamped: the ring-down's damped frequency over sqrt(1 - zeta^2) "
                f"(validation/ringdown_{args.pair}.json); rom_1dof: the validation ROM's model; rom_with_bodies: "
                "the same table with each gear's first bore-clamped torsional mode as a rim on the hub; "
                "rom_with_static_mode_bodies: each body as its static mode under the inertia load (Rayleigh-Ritz); "
                "helical: the bodies from the transverse mesh times the face width (the reference model extrudes it)",
    }
    path = HERE / f"mesh_mode_{args.pair}.json"
    path.write_text(json.dumps(out, indent=2) + "\n")
    log.info("written %s", path)


if __name__ == "__main__":
    main()
