"""How much the former fully integrated element kernels strained a spinning gear through rounding.

Usage: ``python validation/run_rotation_rounding.py [--skip-helical]``.

The explicit models are total Lagrangian: a gear's displacement field carries its rigid rotation, up to its
radius times the angle turned. A rigid rotation has F = Q and no strain. The kernels of git revision
``FORMER_REV`` formed F = I + sum_a u_a (x) b_a from single-precision Gauss gradients, whose rounding breaks
sum_a b_a = 0 by about 1e-7 |b|; with u_a of the size of the radius, that gives a spurious strain that grows
with the angle turned. The package kernels form F from the displacements relative to the element's node 0 and
read double-precision gradients (:func:`gearrom.fe.explicit.kernels.hex8_full_element`).

For each reference mesh turned rigidly about its axis (the spur references' transverse Q4 meshes, and the
helical reference model's whole pair), this script computes, with both kernels, the elastic energy and the
largest nodal force of that pure rotation (exactly zero). For the spur gears it also solves the linear static
response of each bore-clamped gear to the former kernel's spurious forces (scikit-fem, plane strain times the
face width), and reports the tangential displacement over the teeth: the size of the transmission error they
could have caused, to set beside the spur references' dynamic TE (``validation/rom_vs_fe_spur_loaded.json``).
Writes ``validation/rotation_rounding.json``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import os
import platform
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numba
import numpy as np

HERE = Path(__file__).resolve().parent
log = logging.getLogger("run_rotation_rounding")
#: the last revision whose fully integrated kernels used absolute displacements on single-precision gradients
FORMER_REV = "2b7e9a0"
ANGLES_RAD = (1.0, 3.0)


def former_kernels():
    """The fully integrated Q4 and Hex8 kernels of ``FORMER_REV`` (read from git)."""
    src = subprocess.run(["git", "show", f"{FORMER_REV}:gearrom/fe/explicit/kernels.py"], cwd=HERE.parent,
                         check=True, capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "kernels_former.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("kernels_former", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.q4_full_element, mod.hex8_full_element


def _passes(former, package):
    @numba.njit(fastmath=True)
    def run_former(conn, u, Bg, Wg, lam, mu, f):
        w = 0.0
        for e in range(conn.shape[0]):
            w += former(e, conn, u, Bg, Wg, lam, mu, f)
        return w

    @numba.njit(fastmath=True)
    def run_package(conn, u, Bg, Wg, shape, rot, lam, mu, f):
        w = 0.0
        for e in range(conn.shape[0]):
            w += package(e, conn, u, Bg, Wg, shape, rot, lam, mu, f)
        return w
    return run_former, run_package


def spurious(nodes, conn, thickness, lam, mu, former, package, angles=ANGLES_RAD):
    """Energy [J] and nodal forces [N] of a rigid rotation by each angle about z, with both kernels."""
    from gearrom.fe.explicit.geometry import congruent_shapes, full_integration_data

    Bg, Wg = full_integration_data(nodes, conn, *thickness)
    table = congruent_shapes(nodes, conn, Bg, Wg)
    run_former, run_package = _passes(former, package)
    Bg32 = Bg.astype(np.float32)
    out = []
    for th in angles:
        Q = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        u = np.zeros_like(nodes)
        u[:, :2] = nodes[:, :2] @ Q.T - nodes[:, :2]
        f_old = np.zeros_like(u)
        w_old = run_former(conn, u, Bg32, Wg, lam, mu, f_old)
        f_new = np.zeros_like(u)
        w_new = run_package(conn, u, *table, lam, mu, f_new)
        out.append({"angle_rad": th, "Q": Q, "f_former": f_old,
                    "former": {"energy_J": float(w_old), "max_nodal_force_N": float(np.abs(f_old).max())},
                    "package": {"energy_J": float(w_new), "max_nodal_force_N": float(np.abs(f_new).max())}})
    return out


def spur(former_q4, package_q4) -> dict:
    """The spur references' gear meshes: spurious energy, forces and static tangential displacement."""
    import skfem
    from run_ringdown import REFERENCE
    from skfem.models.elasticity import linear_elasticity

    from gearrom.config import load_config
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh
    from gearrom.fe.explicit.model import Material

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-spur").pair
    mesh = REFERENCE["spur"]
    lam, mu = Material().lame
    gears = []
    for i in (0, 1):
        nodes, quads, bore = gear_quad_mesh(pair, i, mesh["outline_size_m"], mesh["body_size_m"], sag=mesh["sag_m"],
                                            periodic=mesh.get("periodic", False))
        basis = skfem.Basis(skfem.MeshQuad(nodes.T.copy(), quads.T.copy()), skfem.ElementVector(skfem.ElementQuad1()))
        K = skfem.asm(linear_elasticity(lam, mu), basis) * pair.face_width
        dofs = basis.nodal_dofs
        r = np.hypot(nodes[:, 0], nodes[:, 1])
        teeth = r > pair.df[i] / 2
        rows = []
        for case in spurious(nodes, quads, (pair.face_width,), lam, mu, former_q4, package_q4):
            load = -(case.pop("f_former") @ case.pop("Q"))       # the residual, turned back to the reference frame
            b = np.zeros(K.shape[0])
            b[dofs[0]], b[dofs[1]] = load[:, 0], load[:, 1]
            x = skfem.solve(*skfem.condense(K, b, D=dofs[:, np.asarray(bore)].ravel()))
            ut = (-nodes[:, 1] * x[dofs[0]] + nodes[:, 0] * x[dofs[1]]) / r
            case["former"]["teeth_tangential_displacement_max_nm"] = float(np.abs(ut[teeth]).max() * 1e9)
            case["former"]["teeth_tangential_displacement_rms_nm"] = float(np.sqrt((ut[teeth] ** 2).mean()) * 1e9)
            rows.append(case)
            log.info("spur gear %d turned %.1f rad: former kernel %.3g J, %.3g N, teeth %.2f nm (max); package "
                     "%.3g J, %.3g N", i, case["angle_rad"], case["former"]["energy_J"],
                     case["former"]["max_nodal_force_N"], case["former"]["teeth_tangential_displacement_max_nm"],
                     case["package"]["energy_J"], case["package"]["max_nodal_force_N"])
        gears.append({"gear": i, "n_elements": int(len(quads)), "angles": rows})
    refs = json.loads((HERE / "rom_vs_fe_spur_loaded.json").read_text())["speeds"]
    fe = {str(s["rpm_in"]): {k: s["metrics"][k]["fe"] for k in ("dte_periodic_rms_um", "gmf1_amplitude_um",
                                                                "gmf2_amplitude_um", "gmf3_amplitude_um")}
          for s in refs}
    return {"gears": gears, "references_fe_um": fe,
            "note": "the spur references turn the pinion by up to 3.1 rad over their 15 ms at 2000 rpm"}


def helical(former_hex8, package_hex8) -> dict:
    """The helical reference model (drawing micro-geometry), both gears turned about their own axes."""
    from run_explicit_helical import loaded_case

    from gearrom.fe.explicit.helicalpair import helical_pair_model

    case = loaded_case(2000.0, config="thesis-helical-drawing")
    model, info = helical_pair_model(case.pair, case.meshes, case.setup, case.mesh["n_layers"], run_angle=None)
    lam, mu = model.material.lame
    n1 = info["n_nodes_gear1"]
    gears = []
    for i, (lo, hi) in enumerate(((0, n1), (n1, model.nodes.shape[0]))):
        sel = np.all((model.elements >= lo) & (model.elements < hi), axis=1)
        conn = model.elements[sel] - lo
        nodes = model.nodes[lo:hi].copy()
        centre = np.array(model.references[i].center if model.references[i].center is not None
                          else nodes[:, :2].mean(axis=0))
        nodes[:, :2] -= centre
        rows = []
        for c in spurious(nodes, conn, (), lam, mu, former_hex8, package_hex8, angles=(0.88, 3.0)):
            c.pop("f_former"), c.pop("Q")
            rows.append(c)
            log.info("helical gear %d turned %.2f rad: former kernel %.3g J, %.3g N; package %.3g J, %.3g N", i,
                     c["angle_rad"], c["former"]["energy_J"], c["former"]["max_nodal_force_N"],
                     c["package"]["energy_J"], c["package"]["max_nodal_force_N"])
        gears.append({"gear": i, "n_elements": int(sel.sum()), "angles": rows})
    return {"gears": gears, "note": "0.88 rad: the input gear's angle when the drawing record was restarted; the "
                                    "record's strain + contact energy there was 0.029 J"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-helical", action="store_true", help="the spur meshes only (the helical model: 5 GB)")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    sys.path.insert(0, str(HERE))
    from gearrom.fe.explicit.kernels import hex8_full_element, q4_full_element

    former_q4, former_hex8 = former_kernels()
    out = {"former_rev": FORMER_REV, "spur": spur(former_q4, q4_full_element)}
    if not args.skip_helical:
        out["helical"] = helical(former_hex8, hex8_full_element)
    out["machine"] = {"platform": platform.platform(), "cpus": os.cpu_count()}
    path = HERE / "rotation_rounding.json"
    path.write_text(json.dumps(out, indent=2) + "\n")
    log.info("wrote %s", path)


if __name__ == "__main__":
    main()
