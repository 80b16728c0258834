"""Explicit FE kernel throughput: element updates per second (whole time step, no contact).

Meshes: a 250 x 200 Q4 plate (50 000 elements, plane strain) and a 40 x 25 x 20 Hex8 block
(20 000 elements), steel, free vibration from a smooth initial velocity field (so every element is
strained). The figure is (elements x steps) / wall time of the compiled loop, measured after a
warm-up call that compiles (or loads from cache) the loop, for the 2-thread (prange by element
colour) and the serial loop; the better of the two is the headline figure. On a loaded machine
the threaded loop suffers badly (threads wait at every colour barrier), hence both. Targets: >= 3e7 for Q4 and
>= 5e6 for Hex8 on 2 cores. The machine is shared with other helpers: figures may be pessimistic.

``--full-only``: adds the fully integrated Q4 / Hex8 throughput and its cost ratio to the one-point
elements, both measured in one run on the same meshes, to the existing results file.

``--helical``: also (or, with ``--helical-only``, only, added to the existing results file) the Hex8
throughput on the helical gear pair mesh of validation/run_explicit_helical.py (sector model, 8
twisted layers, with the node-to-facet contact of the flanks), the whole step including contact, and the
same steps without contact (the contact's share of the step), each the best of three timed runs (the
spread is in ``wall_s_repeats``); target ``HELICAL_TARGET`` on 2 cores.

``--reference-only``: the step of the helical validation reference itself (whole gear bodies, 16 layers, fully
integrated Hex8, flank contact, relative damping; ``validation/run_ringdown.REFERENCE_MESH_HELICAL``) from its
committed loaded static state at 2000 rpm: wall time per step and element updates per second, on both cores,
with the element schedule of the loop (:func:`gearrom.fe.explicit.geometry.schedule_elements`) and, in the
same run, with one pass per greedy colour over the whole mesh (the element order without node-range parts),
and the share of the elements, the contact and the damping in the step (the same steps without contact and
without relative damping). Writes ``hex8_helical_reference`` into the results file.

``--kernel-variants``: on the same reference model and element schedule, the fully integrated Hex8 element
pass alone (no step around it), serial and on both cores, in one run: the package (its kernel
:func:`gearrom.fe.explicit.kernels.hex8_full_element`: displacements read once, forces summed over the Gauss
points locally, written once; Gauss gradients in double precision read from the table of congruent shapes that
``prepare`` builds, :func:`gearrom.fe.explicit.geometry.congruent_shapes`), the same kernel on the table in
single precision and on every element's own single- and double-precision gradients (the forms that stream them
from memory), and the baseline form kept here (:func:`_hex8_full_per_gauss`: own double-precision gradients,
displacements read and forces written at every Gauss point); with the largest force difference to the baseline.
Writes ``hex8_full_kernel_variants``.

``--shape-table``: on the same reference model, the whole step with the shape table against the same loop fed
every element's own gradients, alternated in one run, best of three each, and the difference of the two runs'
gear rotations at the end. Writes ``hex8_helical_shape_table``.
"""
from __future__ import annotations

import os
import sys
import time

import numba
import numpy as np

from _common import peak_memory_MB, write_result
from gearrom.fe.explicit import ExplicitModel, Material, prepare, solve
from gearrom.fe.explicit.kernels import svk_3d
from gearrom.fe.explicit.meshes import box_hex8, rectangle_q4


#: Hex8 element updates per second on the helical pair mesh with flank contact, 2 cores
HELICAL_TARGET = 1e7


def _model(nodes, elements, integration: str = "reduced"):
    L = nodes.max(0) - nodes.min(0)
    v0 = np.zeros_like(nodes)
    v0[:, 0] = 0.1 * np.sin(np.pi * nodes[:, 1] / L[1])
    v0[:, 1] = 0.1 * np.sin(np.pi * nodes[:, 0] / L[0])
    return ExplicitModel(nodes, elements, Material(), thickness=0.01, initial_velocity=v0,
                         hourglass_stiffness=0.05, hourglass_viscosity=0.01, integration=integration)


def measure_full() -> dict:
    """One-point vs fully integrated elements on the same meshes, measured back to back (cost ratio)."""
    out = {}
    for name, mesh, nsteps in (("q4", rectangle_q4(0.25, 0.2, 250, 200), 2000),
                               ("hex8", box_hex8(0.04, 0.025, 0.02, 40, 25, 20), 600)):
        red = measure(_model(*mesh, "reduced"), nsteps)
        full = measure(_model(*mesh, "full"), nsteps)
        out[name] = {"reduced_element_updates_per_s": red["element_updates_per_s"],
                     "full_element_updates_per_s": full["element_updates_per_s"],
                     "full_cost_ratio": red["element_updates_per_s"] / full["element_updates_per_s"],
                     "full_dt_ratio": full["dt_s"] / red["dt_s"], "full": full}
    return out


def measure(model, nsteps: int, d: dict | None = None, repeats: int = 1) -> dict:
    """Throughput of ``nsteps`` steps, parallel and serial loop; the best of ``repeats`` timed runs."""
    d = prepare(model) if d is None else d
    dt = d["dt"]
    ne = model.elements.shape[0]
    out = {"n_elements": ne, "n_nodes": model.nodes.shape[0], "dt_s": dt}
    for parallel in (True, False):
        solve(model, 10 * dt, sample_period=5 * dt, prepared=d, parallel=parallel)   # warm-up / compile
        walls = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = solve(model, nsteps * dt, sample_period=nsteps * dt / 4, prepared=d, chunks=1, parallel=parallel)
            walls.append(time.perf_counter() - t0)
        wall = min(walls)
        key = "parallel" if parallel else "serial"
        out[key] = {"n_steps": res.meta["n_steps"], "wall_s": wall, "wall_s_repeats": walls,
                    "element_updates_per_s": res.meta["n_steps"] * ne / wall,
                    "ns_per_element_step": wall / (res.meta["n_steps"] * ne) * 1e9}
        out["n_passes"] = res.meta["n_passes"]
    out["element_updates_per_s"] = max(out["parallel"]["element_updates_per_s"],
                                       out["serial"]["element_updates_per_s"])
    return out


def measure_helical(nsteps: int = 400, integration: str = "reduced") -> dict:
    """Element updates per second of the helical pair model of the reference runs (contact included)."""
    import importlib.util
    import math
    import warnings
    from pathlib import Path

    from gearrom.config import load_config
    from gearrom.fe.explicit.gearpair import GearPairSetup
    from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model

    spec = importlib.util.spec_from_file_location(
        "run_explicit_helical", Path(__file__).resolve().parents[1] / "validation" / "run_explicit_helical.py")
    ref = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ref)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-helical").pair
    meshes = helical_meshes(pair, ref.OUTLINE, ref.BODY, ref.GRADING)
    rpm = 2000.0
    setup = GearPairSetup(rpm_in=rpm, torque_out=120.0, torque_ramp_time=0.3e-3, mass_scaling_dt=ref.MASS_SCALING_DT,
                          penalty_scale=ref.PENALTY, hourglass_stiffness=ref.HOURGLASS, integration=integration)
    t_end = 0.3e-3 + 6 / (rpm / 60 * pair.z[0])
    model, _ = helical_pair_model(pair, meshes, setup, ref.LAYERS, run_angle=rpm * 2 * math.pi / 60 * t_end)
    d = prepare(model)
    out = measure(model, nsteps, d, repeats=3)
    # the same model and steps without contact (no slave nodes): the contact's share of the step
    empty = np.zeros(0, np.int64)
    bare = {**d, "slaves": empty, "s_pair": empty, "cand": np.zeros((0, d["cand"].shape[1]), np.int64),
            "ncand": empty.copy(), "gap": np.zeros(0), "c_nodes": empty.copy()}
    out["without_contact"] = measure(model, nsteps, bare, repeats=3)
    for key in ("parallel", "serial"):
        with_c = out[key]["ns_per_element_step"]
        out[key]["contact_share"] = 1.0 - out["without_contact"][key]["ns_per_element_step"] / with_c
    out["n_contact_slaves"] = int(d["slaves"].size)
    out["model"] = (f"helical pair, {ref.LAYERS} layers, {ref.OUTLINE * 1e3:g} mm outline, sector, {integration} "
                    "integration, with flank contact "
                    "(first steps from the start position: contact search active, few contacts)")
    return out


def _colour_schedule(d: dict, conn: np.ndarray, n: int) -> dict:
    """``d`` with the element order of one parallel pass per greedy colour over the whole mesh."""
    from gearrom.fe.explicit.geometry import colour_blocks

    order, ends, per = colour_blocks(conn, np.arange(conn.shape[0]), n)
    out = dict(d)
    inv = np.empty_like(d["element_order"])
    inv[d["element_order"]] = np.arange(d["element_order"].size)     # prepared position of each model element
    pos = inv[order]
    for k in ("conn", "B", "V0", "gamma", "khg", "chg", "full", "gshape", "grot"):
        out[k] = np.ascontiguousarray(d[k][pos])
    out["bptr"] = np.asarray([0] + ends, np.int64)
    out["cptr"] = np.concatenate([[0], np.cumsum(per)]).astype(np.int64)
    return out


def _reference_model():
    """The helical validation reference model from its committed loaded state, and its prepared arrays."""
    import warnings
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "validation"))
    from run_ringdown import REFERENCE_MESH_HELICAL as mesh, reference_meshes, reference_setup

    from gearrom.config import load_config
    from gearrom.fe.explicit.gearpair import loaded_model, start_state_key, stored_start_state
    from gearrom.fe.explicit.helicalpair import helical_pair_model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-helical").pair
    state_file = root / "validation" / "checkpoints" / "helical_2000rpm_loaded.ckpt.npz"
    setup = reference_setup(mesh, rpm_in=2000.0, torque_out=120.0, mu=0.0, start="loaded",
                            relative_damping=146800.0)
    model, info = helical_pair_model(pair, reference_meshes(pair, mesh), setup, mesh["n_layers"])

    def missing():
        raise SystemExit(f"{state_file}.loaded.npz (the reference's loaded static state of this model and contact "
                         "rule) is missing")

    state = stored_start_state(state_file, ".loaded.npz", "te", model.nodes.shape, 120.0, missing,
                               key=start_state_key(model))
    model = loaded_model(model, info, setup, (state[0], state[1], 0.0))
    return model, prepare(model, 0.9, mesh["max_candidates"])


def measure_reference(nsteps: int = 60) -> dict:
    """Wall time per step of the helical validation reference model (module docstring, ``--reference-only``)."""
    import dataclasses

    model, d = _reference_model()
    ne = model.elements.shape[0]
    dt = d["dt"]
    empty = np.zeros(0, np.int64)
    bare = {**d, "slaves": empty, "s_pair": empty, "cand": np.zeros((0, d["cand"].shape[1]), np.int64),
            "ncand": empty.copy(), "gap": np.zeros(0), "c_nodes": empty.copy()}
    undamped = dataclasses.replace(model, relative_damping=0.0)
    variants = {"step": (model, d), "colour_passes": (model, _colour_schedule(d, model.elements, model.nodes.shape[0])),
                "without_contact": (model, bare), "without_damping": (undamped, d), "elements_only": (undamped, bare)}
    out = {"n_elements": ne, "n_nodes": int(model.nodes.shape[0]), "n_contact_slaves": int(d["slaves"].size),
           "dt_s": dt, "n_steps": nsteps, "n_passes": int(d["cptr"].size - 1),
           "n_passes_colour": int(variants["colour_passes"][1]["cptr"].size - 1)}
    for name, (m, dd) in variants.items():
        solve(m, 4 * dt, sample_period=2 * dt, prepared=dd, parallel=True, chunks=1)     # compile / warm up
        t0 = time.perf_counter()
        res = solve(m, nsteps * dt, sample_period=nsteps * dt / 2, prepared=dd, parallel=True, chunks=1)
        wall = (time.perf_counter() - t0) / res.meta["n_steps"]
        out[name] = {"ms_per_step": wall * 1e3, "element_updates_per_s": ne / wall}
        print(f"{name}: {wall * 1e3:.1f} ms per step, {ne / wall:.3g} element updates per s", flush=True)
    out["speedup_vs_colour_passes"] = out["colour_passes"]["ms_per_step"] / out["step"]["ms_per_step"]
    out["elements_share"] = out["elements_only"]["ms_per_step"] / out["step"]["ms_per_step"]
    out["record_compute_h"] = out["step"]["ms_per_step"] * 1e-3 * 18.75e-3 / dt / 3600
    out["model"] = ("helical validation reference (run_ringdown.REFERENCE_MESH_HELICAL), loaded start at 2000 rpm "
                    "and 120 N m, 2 threads; record_compute_h: one 18.75 ms record (10 settling + 10 recorded "
                    "mesh periods at 2000 rpm) at this step")
    return out


def _own_gradients(model, d: dict) -> dict:
    """``d`` with every element's own Gauss gradients (prepared order, single precision) instead of the table."""
    from gearrom.fe.explicit.geometry import full_integration_data

    Bg, Wg = full_integration_data(model.nodes, model.elements)
    order = d["element_order"]
    ne = order.size
    return {**d, "Bg": np.ascontiguousarray(Bg[order], dtype=np.float32), "Wg": np.ascontiguousarray(Wg[order]),
            "gshape": np.arange(ne, dtype=np.int64), "grot": np.tile([1.0, 0.0], (ne, 1))}


def measure_shape_table(nsteps: int = 60, repeats: int = 3) -> dict:
    """Step time of the reference model with the shape table and with own gradients (``--shape-table``)."""
    model, d = _reference_model()
    dt = d["dt"]
    variants = {"shape_table": d, "own_gradients": _own_gradients(model, d)}
    walls = {k: [] for k in variants}
    theta = {}
    for _ in range(repeats):
        for name, dd in variants.items():
            solve(model, 4 * dt, sample_period=2 * dt, prepared=dd, parallel=True, chunks=1)
            t0 = time.perf_counter()
            res = solve(model, nsteps * dt, sample_period=nsteps * dt / 2, prepared=dd, parallel=True, chunks=1)
            walls[name].append((time.perf_counter() - t0) / res.meta["n_steps"] * 1e3)
            theta[name] = np.asarray(res.theta)[-1]
            print(f"{name}: {walls[name][-1]:.1f} ms per step", flush=True)
    out = {name: {"ms_per_step": min(w), "ms_per_step_repeats": w} for name, w in walls.items()}
    out["speedup"] = out["own_gradients"]["ms_per_step"] / out["shape_table"]["ms_per_step"]
    out["n_shapes"] = int(len(d["Bg"]))
    out["n_elements"] = int(model.elements.shape[0])
    out["max_rotation_difference_rad"] = float(np.abs(theta["shape_table"] - theta["own_gradients"]).max())
    out["n_steps"] = nsteps
    out["model"] = "helical validation reference (run_ringdown.REFERENCE_MESH_HELICAL), loaded start, 2 threads"
    return out


@numba.njit(cache=True, fastmath=True, inline="always")
def _hex8_full_per_gauss(e, conn, u, Bg, Wg, shape, rot, lam, mu, f):
    """Baseline fully integrated Hex8 element on its own gradients (``shape``, ``rot`` unused): the
    displacements are read and the forces written at every Gauss point (same arithmetic as the package kernel,
    other memory traffic)."""
    wint = 0.0
    for g in range(8):
        w = Wg[e, g]
        F00 = 1.0; F01 = 0.0; F02 = 0.0
        F10 = 0.0; F11 = 1.0; F12 = 0.0
        F20 = 0.0; F21 = 0.0; F22 = 1.0
        for a in range(8):
            n = conn[e, a]
            ux = u[n, 0]; uy = u[n, 1]; uz = u[n, 2]
            bx = Bg[e, g, a, 0]; by = Bg[e, g, a, 1]; bz = Bg[e, g, a, 2]
            F00 += ux * bx; F01 += ux * by; F02 += ux * bz
            F10 += uy * bx; F11 += uy * by; F12 += uy * bz
            F20 += uz * bx; F21 += uz * by; F22 += uz * bz
        P00, P01, P02, P10, P11, P12, P20, P21, P22, psi = svk_3d(F00, F01, F02, F10, F11, F12, F20, F21, F22,
                                                                  lam, mu)
        P00 *= w; P01 *= w; P02 *= w
        P10 *= w; P11 *= w; P12 *= w
        P20 *= w; P21 *= w; P22 *= w
        wint += w * psi
        for a in range(8):
            n = conn[e, a]
            bx = Bg[e, g, a, 0]; by = Bg[e, g, a, 1]; bz = Bg[e, g, a, 2]
            f[n, 0] -= P00 * bx + P01 * by + P02 * bz
            f[n, 1] -= P10 * bx + P11 * by + P12 * bz
            f[n, 2] -= P20 * bx + P21 * by + P22 * bz
    return wint


def _element_pass(kernel):
    """The loop's element pass (passes in sequence, the blocks of a pass in parallel) with ``kernel``."""
    @numba.njit(parallel=True, fastmath=True)
    def run(conn, u, Bg, Wg, shape, rot, lam, mu, f, cptr, bptr):
        wint = 0.0
        for c in range(cptr.shape[0] - 1):
            for b in numba.prange(cptr[c], cptr[c + 1]):
                for e in range(bptr[b], bptr[b + 1]):
                    wint += kernel(e, conn, u, Bg, Wg, shape, rot, lam, mu, f)
        return wint
    return run


def measure_kernel_variants(repeats: int = 5) -> dict:
    """The element pass of the reference model with the package kernel and the baseline (``--kernel-variants``)."""
    from gearrom.fe.explicit.kernels import hex8_full_element

    model, d = _reference_model()
    own = _own_gradients(model, d)
    conn, cptr, bptr = d["conn"], d["cptr"], d["bptr"]
    u = np.random.default_rng(0).normal(0.0, 1e-6, model.nodes.shape)     # every element strained
    lam, mu = float(d["lam"]), float(d["mu"])
    ne = conn.shape[0]
    out = {"n_elements": ne, "n_shapes": int(len(d["Bg"])), "repeats": repeats}
    forces = {}
    own64 = {**own, "Bg": own["Bg"].astype(np.float64)}
    package, baseline = _element_pass(hex8_full_element), _element_pass(_hex8_full_per_gauss)
    table32 = {**d, "Bg": d["Bg"].astype(np.float32)}
    variants = (("package", package, d), ("package_float32_table", package, table32),
                ("package_own_gradients", package, own),
                ("package_own_float64_gradients", package, own64), ("per_gauss_baseline", baseline, own64))
    compared = [name for name, _, _ in variants[:-1]]
    for threads in (1, 2):
        numba.set_num_threads(threads)
        for name, run, arr in variants:
            grads = (arr["Bg"], arr["Wg"], arr["gshape"], arr["grot"])
            f = np.zeros_like(u)
            run(conn, u, *grads, lam, mu, f, cptr, bptr)     # compile
            forces[name] = f
            walls = []
            for _ in range(repeats):
                f[:] = 0.0
                t0 = time.perf_counter()
                run(conn, u, *grads, lam, mu, f, cptr, bptr)
                walls.append(time.perf_counter() - t0)
            wall = min(walls)
            out[f"{name}_{threads}_threads"] = {"ms_per_pass": wall * 1e3, "element_updates_per_s": ne / wall,
                                                "wall_s_repeats": walls}
            print(f"{name}, {threads} thread(s): {wall * 1e3:.1f} ms per pass, {ne / wall:.3g} element updates per s",
                  flush=True)
        for name in compared:
            out[f"speedup_{name}_{threads}_threads"] = (out[f"per_gauss_baseline_{threads}_threads"]["ms_per_pass"]
                                                        / out[f"{name}_{threads}_threads"]["ms_per_pass"])
    scale = np.abs(forces["per_gauss_baseline"]).max()
    for name in compared:
        out[f"max_force_difference_rel_{name}"] = float(np.abs(forces[name] - forces["per_gauss_baseline"]).max()
                                                        / scale)
    out["model"] = "helical validation reference (run_ringdown.REFERENCE_MESH_HELICAL), element pass only"
    return out


def _add_figure(key: str, value: dict, note: str | None = None) -> None:
    """Add one measured figure (and the load average after it) to the stored kernel results."""
    import json

    from _common import RESULTS

    figures = json.loads((RESULTS / "bench_explicit_kernel.json").read_text())["figures"]
    figures[key] = value
    figures[f"{key}_load_average_1_5_15"] = list(os.getloadavg())
    if note is not None:
        figures[f"{key}_note"] = note
    write_result("bench_explicit_kernel", figures)


def main() -> None:
    import json
    import sys

    single = {   # flag: (key, measurement, note) -- one figure added to the stored results
        "--full-only": ("full_integration", measure_full,
                        "2x2 / 2x2x2 Gauss elements without hourglass control vs the one-point "
                        "elements, measured back to back in one run (machine section: its date)"),
        "--kernel-variants": ("hex8_full_kernel_variants", measure_kernel_variants, None),
        "--shape-table": ("hex8_helical_shape_table", measure_shape_table, None),
        "--reference-only": ("hex8_helical_reference", measure_reference, None),
    }
    for flag, (key, measure_one, note) in single.items():
        if flag in sys.argv:
            _add_figure(key, measure_one(), note)
            return
    if "--helical-only" in sys.argv:
        from _common import RESULTS

        figures = json.loads((RESULTS / "bench_explicit_kernel.json").read_text())["figures"]
        figures["hex8_helical"] = measure_helical()
        figures["hex8_helical_target"] = HELICAL_TARGET
        figures["hex8_helical_meets_target"] = figures["hex8_helical"]["element_updates_per_s"] >= HELICAL_TARGET
        figures["hex8_helical_full"] = measure_helical(integration="full")     # the references' elements
        figures["hex8_helical_load_average_1_5_15"] = list(os.getloadavg())
        figures["hex8_helical_note"] = ("measured later than the q4/hex8 block figures (machine section: date of this "
                                        "measurement; load average at the end of it in hex8_helical_load_average)")
        write_result("bench_explicit_kernel", figures)
        return
    q4 = measure(_model(*rectangle_q4(0.25, 0.2, 250, 200)), 2000)
    hx = measure(_model(*box_hex8(0.04, 0.025, 0.02, 40, 25, 20)), 600)
    figures = {
        "threads": numba.get_num_threads(),
        "q4": q4,
        "hex8": hx,
        "q4_target": 3e7,
        "hex8_target": 5e6,
        "q4_meets_target": q4["element_updates_per_s"] >= 3e7,
        "hex8_meets_target": hx["element_updates_per_s"] >= 5e6,
        "peak_memory_MB": peak_memory_MB(),
        "load_average_1_5_15": list(os.getloadavg()),
        "note": "2 cores shared with other helpers during the run; whole step incl. node update and "
                "energy reductions, no contact",
    }
    if "--helical" in sys.argv:
        figures["hex8_helical"] = measure_helical()
        figures["hex8_helical_target"] = HELICAL_TARGET
        figures["hex8_helical_meets_target"] = figures["hex8_helical"]["element_updates_per_s"] >= HELICAL_TARGET
    write_result("bench_explicit_kernel", figures)


if __name__ == "__main__":
    main()
