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

1. each gear's bore-clamped torsional modes (scikit-fem, consistent mass) with the effective inertia of each
   about the axis, ``J_j = (phi_j^T M r)^2`` for mass-normalised ``phi_j`` and the rigid rotation field ``r``
   (``sum_j J_j`` over all modes is the gear's inertia without the bore);
2. a body model of each gear: its first torsional mode as a rim of inertia ``J_r`` on a torsional spring
   ``k_b = J_r w_b^2`` to the hub (the bore), the rest of the inertia on the hub;
3. the mesh mode of the ROM's 1-DOF model and of the model with the bodies (input rim on the held bore,
   the mesh spring with the bodies' compliance taken out of the table's, output rim on the output hub),
   against the ring-down's frequency.

It writes ``validation/mesh_mode_<pair>.json``. The table is the validation ROM's (load-dependent LTCA table
on the reference flank grid or strips, as ``gearrom validate`` builds it); its tangent stiffness is taken over
the mesh cycle at ``--torque`` and at the ring-down's position and stepped torque. The helical bodies come
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


def body_modes(nodes: np.ndarray, quads: np.ndarray, bore: np.ndarray, width: float, n_modes: int = 12,
               material=None) -> dict:
    """Bore-clamped modes of one gear (plane strain, ``width`` thick): frequencies and effective inertias
    about the gear axis (the mesh's origin)."""
    import scipy.sparse.linalg as sla
    from skfem import Basis, BilinearForm, ElementQuad1, ElementVector, MeshQuad1, condense
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from gearrom.fe.explicit.model import Material

    mat = material or Material()
    mesh = MeshQuad1(np.ascontiguousarray(nodes.T), np.ascontiguousarray(quads.T))
    basis = Basis(mesh, ElementVector(ElementQuad1()))
    lam, mu = lame_parameters(mat.E, mat.nu)     # plane strain
    K = width * linear_elasticity(lam, mu).assemble(basis)

    @BilinearForm
    def mass(u, v, w):
        return mat.rho * width * dot(u, v)

    M = mass.assemble(basis)
    # nodal DOFs of ElementVector(Quad1): x of node i at 2 i, y at 2 i + 1
    fixed = np.sort(np.concatenate([2 * np.asarray(bore), 2 * np.asarray(bore) + 1]))
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    Kf, Mf = K[free][:, free].tocsc(), M[free][:, free].tocsc()
    rot = np.zeros(K.shape[0])
    rot[0::2], rot[1::2] = -nodes[:, 1], nodes[:, 0]
    r = rot[free]
    # the static mode: the body's deflection under the inertia load of a unit angular acceleration (M r), scaled
    # to a unit mass-weighted mean rotation r^T M psi / r^T M r = 1
    psi = sla.spsolve(Kf, Mf @ r)
    psi /= (r @ (Mf @ psi)) / (r @ (Mf @ r))
    static = {"k_body_Nm_per_rad": float(psi @ (Kf @ psi)), "M_qq_kgm2": float(psi @ (Mf @ psi))}
    w2, phi = sla.eigsh(Kf, k=n_modes, M=Mf, sigma=0.0, which="LM")
    order = np.argsort(w2)
    w2, phi = w2[order], phi[:, order]
    phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, Mf @ phi))
    gamma = phi.T @ (Mf @ r)
    J_free = float(r @ (Mf @ r))
    J_all = float(rot @ (M @ rot))
    return {"frequency_Hz": (np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)).tolist(),
            "effective_inertia_kgm2": (gamma ** 2).tolist(), "inertia_without_bore_kgm2": J_free,
            "inertia_kgm2": J_all, "n_dofs_free": int(free.size), "static_mode": static}


def torsional_body(modes: dict) -> dict:
    """The body model of one gear: its mode of largest effective inertia as the rim (``J_r``, ``k_b``), the rest
    of the gear's inertia on the hub."""
    J = np.asarray(modes["effective_inertia_kgm2"])
    j = int(np.argmax(J))
    w = 2 * np.pi * modes["frequency_Hz"][j]
    return {"mode": j, "frequency_Hz": modes["frequency_Hz"][j], "J_rim_kgm2": float(J[j]),
            "J_hub_kgm2": modes["inertia_kgm2"] - float(J[j]), "k_body_Nm_per_rad": float(J[j] * w * w),
            "rim_share_of_inertia": float(J[j] / modes["inertia_kgm2"])}


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
    rotation and the deflection under the inertia load, :func:`body_modes`): DOFs the input's elastic rotation
    q1, the output hub theta_2h and its elastic rotation q2; the mesh spring on rb1 q1 - rb2 (theta_2h + q2)
    with the table's compliance less both bodies' static-mode compliance."""
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
    from gearrom.validation.pair_rom import fe_start_mesh_phase, polar_inertia

    pair = load_config(CONFIG[args.pair]).pair
    mesh = REFERENCE[args.pair]
    meshes = reference_meshes(pair, mesh)
    width = pair.face_width
    bodies, modes = [], []
    for i, (nodes, quads, bore) in enumerate(meshes[:2]):
        m = body_modes(nodes, quads, bore, width, args.modes)
        m["inertia_exact_kgm2"] = polar_inertia(nodes, quads, (0.0, 0.0), 7850.0, width)
        modes.append(m)
        bodies.append(torsional_body(m))
        log.info("gear %d: first torsional body mode %.0f Hz, rim %.1f %% of the inertia", i,
                 bodies[-1]["frequency_Hz"], 100 * bodies[-1]["rim_share_of_inertia"])
    cal = calibration(args.pair)
    f_fe = float(cal["runs"][-1]["frequency_Hz"])
    zeta = float(cal["zeta_measured"])
    f_fe_undamped = f_fe / np.sqrt(1 - zeta ** 2)
    T = args.torque
    T_ring = float(cal["torque_step_Nm"][1])       # the ring-down oscillates about the stepped torque's state
    theta0 = fe_start_mesh_phase(pair)             # the ring-down holds the input at the FE's start position
    k_at = table_tangent(pair, T, T_ring, theta0)
    label = k_at.pop("table")
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
        "ringdown_mesh_phase_rad": theta0, "output_inertia_kgm2": J_out, "fe_ringdown_undamped_Hz": f_fe_undamped,
        "gears": [{"modes": m, "body_model": b} for m, b in zip(modes, bodies)],
        "cases": cases,
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
