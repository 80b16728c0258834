"""Assemble the flat arrays of an :class:`ExplicitModel` and run the compiled loop."""
from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

import numba
import numpy as np

from gearrom.errors import ConfigError, ModelError, RunInterrupted
from gearrom.fe.explicit.contact import facet_neighbours, facet_sags
from gearrom.fe.explicit.elements import element_type
from gearrom.fe.explicit.geometry import congruent_shapes, nodal_omega2, schedule_elements
from gearrom.fe.explicit.loop import (CONTACT_ARRAYS, ELEMENT_ARRAYS, LOAD_ARRAYS, NE_OUT, NODE_ARRAYS, OUTPUT_ARRAYS,
                                      REFERENCE_ARRAYS, STATE_ARRAYS, ramp, run_loop_parallel, run_loop_serial)
from gearrom.fe.explicit.model import ExplicitModel
from gearrom.fe.explicit.result import ExplicitResult

log = logging.getLogger(__name__)

__all__ = ["prepare", "solve", "stable_dt"]


def _element_of_segments(conn: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Index of the element owning each segment (all segment nodes in one element)."""
    owner = {}
    for e, row in enumerate(conn):
        for n in row:
            owner.setdefault(int(n), []).append(e)
    out = np.empty(len(segs), np.int64)
    for s, seg in enumerate(segs):
        cands = set(owner.get(int(seg[0]), []))
        for n in seg[1:]:
            cands &= set(owner.get(int(n), []))
        if not cands:
            raise ConfigError(f"master segment {s} {seg.tolist()} is not a face of any element")
        out[s] = min(cands)
    return out


def prepare(model: ExplicitModel, safety: float = 0.9, max_candidates: int | None = None) -> dict:
    """Precompute everything the loop needs (geometry, masses, element schedule, BC and contact arrays).

    ``max_candidates``: master segments kept per slave node by the contact search (default 8 in 2D, 32 in
    3D: bilinear facets of twisted flanks are long axially, so the facet that holds a node's projection is
    often not among the few nearest centroids, and a contact found only when deep blows the run up).
    """
    if not 0 < safety <= 1:
        raise ConfigError(f"safety must be in (0, 1], got {safety}")
    X = model.nodes
    n, dim = X.shape
    if max_candidates is None:
        max_candidates = 8 if dim == 2 else 32
    mat = model.material
    lam, mu = mat.lame
    conn0 = model.elements
    ne, nen = conn0.shape
    etype = element_type(dim, nen, model.integration)
    el = etype.precompute(X, conn0, model.thickness, lam, mu, mat.rho, model.hourglass_stiffness,
                          model.hourglass_viscosity)
    B, V0, gamma, khg, chg, Bg, Wg, lam_e = el.B, el.V0, el.gamma, el.khg, el.chg, el.Bg, el.Wg, el.lam_max
    mass = np.zeros(n)
    np.add.at(mass, conn0, mat.rho * el.me)
    if np.any(mass <= 0):
        raise ModelError(f"node {int(np.argmin(mass))} belongs to no element (zero mass)")
    full = np.full(ne, el.full, np.uint8)
    node_w2 = nodal_omega2(conn0, lam_e, mass)
    order, bptr, cptr = schedule_elements(conn0, n, numba.get_num_threads())
    # The fully integrated element pass reads Gauss-point gradients for every element; streamed from memory
    # they bound its speed. Elements that are rotated copies of one shape (cyclic teeth, twisted layers) read
    # the shape's gradients from a small table (geometry.congruent_shapes) that stays in cache; the others
    # keep their own.
    if el.full:
        Bg, Wg, gshape, grot = congruent_shapes(X, conn0, Bg, Wg)
        log.info("element pass: %d gradient shapes for %d fully integrated elements", len(Bg), ne)
    else:
        Bg, Wg = Bg[:1], Wg[:1]
        gshape, grot = np.zeros(ne, np.int64), np.tile([1.0, 0.0], (ne, 1))
    gshape, grot = gshape[order], grot[order]
    d = dict(conn=np.ascontiguousarray(conn0[order]), B=B[order], V0=V0[order], gamma=gamma[order],
             khg=khg[order], chg=chg[order], cptr=cptr, bptr=bptr, element_order=order, lam=lam, mu=mu,
             mass=mass, dim=dim, n=n, full=full[order], Bg=np.ascontiguousarray(Bg),
             Wg=np.ascontiguousarray(Wg), gshape=np.ascontiguousarray(gshape), grot=np.ascontiguousarray(grot))
    # fixed DOFs
    fixmask = np.zeros((n, dim), np.uint8)
    for name, comps in model.fixed.items():
        for c in comps:
            fixmask[model.node_sets[name], c] = 1
    d["fixmask"] = fixmask
    # rigid references
    kind = -np.ones(n, np.int64)
    extra_w2 = [0.0]
    nr = len(model.references)
    r_nodes, r_ptr, r_off = [], [0], []
    R = {k: np.zeros(nr) for k in ("M", "J", "speed", "ramp", "torque", "tramp", "k", "c", "kb", "cb")}
    r_mode = np.zeros(nr, np.int64)
    r_fixtr = np.zeros(nr, np.int64)
    r_center = np.zeros((nr, dim))
    for r, ref in enumerate(model.references):
        ids = np.unique(model.node_sets[ref.nodes])
        if ids.size < 2:
            raise ConfigError(f"RigidReference {ref.nodes!r}: node set needs >= 2 nodes")
        if np.any(kind[ids] >= 0):
            raise ConfigError(f"RigidReference {ref.nodes!r}: nodes already tied to another reference")
        kind[ids] = r
        m = mass[ids]
        c = X[ids].mean(axis=0)
        if ref.center is not None:
            c[:2] = ref.center
        off = X[ids] - c
        r_center[r] = c
        r_nodes.append(ids)
        r_off.append(off[:, :2])
        r_ptr.append(r_ptr[-1] + ids.size)
        R["M"][r] = m.sum() + ref.mass
        R["J"][r] = (m * (off[:, 0] ** 2 + off[:, 1] ** 2)).sum() + ref.inertia
        R["speed"][r] = ref.speed if ref.speed is not None else 0.0
        R["ramp"][r], R["torque"][r], R["tramp"][r] = ref.ramp_time, ref.torque, ref.torque_ramp_time
        R["k"][r], R["c"][r], R["kb"][r], R["cb"][r] = ref.spring_k, ref.spring_c, ref.bearing_k, ref.bearing_c
        if ref.speed is None:
            r_mode[r] = 0
        else:
            r_mode[r] = 2 if (ref.spring_k > 0 or ref.spring_c > 0) else 1
        r_fixtr[r] = 1 if ref.fix_translation else 0
        extra_w2.append(ref.bearing_k / R["M"][r])
        extra_w2.append(ref.spring_k / R["J"][r])
    d["body"] = _bodies(model, kind) if model.relative_damping > 0 else -np.ones(n, np.int64)
    d["r_fd"] = np.zeros((nr, 4))
    d.update(kind=kind, r_nodes=np.concatenate(r_nodes) if nr else np.zeros(0, np.int64),
             r_ptr=np.array(r_ptr, np.int64), r_off=np.concatenate(r_off) if nr else np.zeros((0, 2)),
             r_mode=r_mode, r_fixtr=r_fixtr, r_center=r_center, **{"r_" + k: v for k, v in R.items()})
    d.update(_load_arrays(model, dim))
    d.update(_contact_arrays(model, conn0, V0, lam, mu, mass, node_w2, max_candidates))
    # selective mass scaling of the nodes below the target step (free nodes only)
    d["added_mass"] = 0.0
    if model.mass_scaling_dt > 0:
        w2t = (2.0 / model.mass_scaling_dt) ** 2
        low = (node_w2 > w2t) & (kind < 0)
        extra = mass[low] * (node_w2[low] / w2t - 1.0)
        d["added_mass"] = float(extra.sum())
        d["n_scaled_nodes"] = int(low.sum())
        mass[low] += extra
        node_w2[low] = w2t
        d["mass"] = mass
    # tied nodes move with their reference: their bound is replaced by the reference's own
    free_w2 = node_w2[kind < 0].max() if np.any(kind < 0) else 0.0
    d["dt_stable"] = 2.0 / math.sqrt(max(free_w2, max(extra_w2)))
    d["dt"] = safety * d["dt_stable"]
    return d


def _bodies(model: ExplicitModel, kind: np.ndarray) -> np.ndarray:
    """Per node, the reference whose rigid frame the relative damping uses (-1: none).

    A node belongs to the reference whose tied nodes lie in the same connected part of the mesh.

    Raises
    ------
    ConfigError
        Two references are tied to one connected part (its rigid frame is ambiguous).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = model.nodes.shape[0]
    conn = model.elements
    a = conn.ravel()
    b = np.roll(conn, -1, axis=1).ravel()
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    owner: dict[int, int] = {}
    for r, ref in enumerate(model.references):
        for lab in np.unique(label[kind == r]):
            if owner.setdefault(int(lab), r) != r:
                raise ConfigError(f"relative_damping: references {model.references[owner[int(lab)]].nodes!r} and "
                                  f"{ref.nodes!r} are tied to the same body; its rigid frame is ambiguous")
    body = np.array([owner.get(int(lab), -1) for lab in label], np.int64)
    loose = int(np.count_nonzero((body < 0) & (kind < 0)))
    if loose:
        log.warning("relative_damping: %d nodes belong to no body with a reference and stay undamped", loose)
    return body


def _load_arrays(model: ExplicitModel, dim: int) -> dict:
    """Nodal loads as flat arrays: node ids per load (``ld_ptr``), force vectors and time tables."""
    nl = len(model.loads)
    npts = max([len(ld.times) for ld in model.loads], default=1)
    ld_t = np.zeros((nl, npts))
    ld_val = np.zeros((nl, npts))
    ld_npts = np.zeros(nl, np.int64)
    ld_nodes, ld_ptr = [], [0]
    for l, ld in enumerate(model.loads):
        ld_t[l, :len(ld.times)] = ld.times
        ld_val[l, :len(ld.times)] = ld.factors
        ld_npts[l] = len(ld.times)
        ids = model.node_sets[ld.nodes]
        ld_nodes.append(ids)
        ld_ptr.append(ld_ptr[-1] + ids.size)
    return dict(ld_nodes=np.concatenate(ld_nodes) if nl else np.zeros(0, np.int64),
             ld_ptr=np.array(ld_ptr, np.int64),
             ld_force=np.array([ld.force for ld in model.loads], float).reshape(nl, dim),
             ld_t=ld_t, ld_val=ld_val, ld_npts=ld_npts)


def _contact_arrays(model: ExplicitModel, conn0, V0, lam: float, mu: float, mass: np.ndarray, node_w2: np.ndarray,
                    max_candidates: int) -> dict:
    """Contact pairs as flat arrays (slaves, master segments, penalties, search buffers). Adds the penalty
    springs' share to the nodal frequency bound ``node_w2`` [1/s^2] in place."""
    X = model.nodes
    dim = X.shape[1]
    nsn = 2 if dim == 2 else 4
    slaves, s_pair, segs, g_pair, g_k, g_rad = [], [], [], [], [], []
    p_mu, p_vreg, p_depth = [], [], []
    for p, cp in enumerate(model.contacts):
        sl = np.unique(model.node_sets[cp.slave])
        sg = model.surfaces[cp.master]
        if sg.shape[0] == 0 or sl.size == 0:
            raise ConfigError(f"ContactPair {cp.slave!r}/{cp.master!r}: empty slave set or master surface")
        own = _element_of_segments(conn0, sg)
        xs = X[sg]
        if dim == 2:
            area = np.linalg.norm(xs[:, 1] - xs[:, 0], axis=1) * model.thickness
        else:
            area = 0.5 * np.linalg.norm(np.cross(xs[:, 2] - xs[:, 0], xs[:, 3] - xs[:, 1]), axis=1)
        # one penalty per pair (the median of the per-segment estimate scale (lambda + 2 mu) A^2 / V): the
        # potential k g^2 / 2 of a node then stays continuous when it passes from one master segment to
        # the next; per-segment values would create or destroy (k2 - k1) g^2 / 2 at every such passage
        k = np.full(len(sg), cp.penalty_scale * np.median((lam + 2 * mu) * area ** 2 / V0[own]))
        cen = xs.mean(axis=1)
        rad = np.linalg.norm(xs - cen[:, None, :], axis=2).max(axis=1)
        hel = (V0[own] / (model.thickness if dim == 2 else 1.0)) ** (1.0 / dim)
        depth = cp.capture_depth if cp.capture_depth is not None else 0.5 * hel.min()
        slaves.append(sl); s_pair.append(np.full(sl.size, p))
        segs.append(sg); g_pair.append(np.full(len(sg), p)); g_k.append(k); g_rad.append(rad)
        p_mu.append(cp.mu); p_vreg.append(cp.v_reg); p_depth.append(depth)
        # the penalty springs add at most 2 k to a slave node and 4 k to a master node (two slaves)
        node_w2[sl] += 2 * k.max() / mass[sl]
        mn = np.unique(sg)
        node_w2[mn] += 4 * k.max() / mass[mn]
    nc = len(model.contacts)
    d = dict(slaves=np.concatenate(slaves) if nc else np.zeros(0, np.int64),
             s_pair=np.concatenate(s_pair).astype(np.int64) if nc else np.zeros(0, np.int64),
             segs=np.concatenate(segs) if nc else np.zeros((0, nsn), np.int64),
             g_pair=np.concatenate(g_pair).astype(np.int64) if nc else np.zeros(0, np.int64),
             g_k=np.concatenate(g_k) if nc else np.zeros(0), g_rad=np.concatenate(g_rad) if nc else np.zeros(0),
             p_mu=np.array(p_mu, float), p_vreg=np.array(p_vreg, float),
             p_depth=np.array(p_depth if nc else [0.0], float))
    margin = max(p_depth) if nc else 0.0
    d["margin"] = margin
    d["cell_h"] = (d["g_rad"].max() + 2 * margin) if nc else 1.0
    ns = d["slaves"].size
    d["head"] = np.zeros(4 * (ns + len(d["segs"])) + 1024, np.int64)
    d["nxt"] = np.zeros(max(len(d["segs"]), 1), np.int64)
    d["cand"] = np.zeros((ns, max_candidates), np.int64)
    d["ncand"] = np.zeros(ns, np.int64)
    d["gap"] = np.zeros(ns)
    d["seg_open"] = _open_edges(d["segs"], d["g_pair"])
    d["seg_sag"] = facet_sags(model.nodes, d["segs"], d["g_pair"]) if nc else np.zeros((0, 2))
    d["c_nodes"] = np.unique(np.concatenate([d["slaves"], d["segs"].ravel()])) if nc else np.zeros(0, np.int64)
    return d


def stable_dt(model: ExplicitModel, safety: float = 0.9) -> float:
    """Stable time step of ``model`` times ``safety``, s."""
    return prepare(model, safety)["dt"]


def _initial_state(model: ExplicitModel, d: dict):
    n, dim = model.nodes.shape
    u = np.zeros((n, dim)) if model.initial_displacement is None else model.initial_displacement.copy()
    v = np.zeros((n, dim)) if model.initial_velocity is None else model.initial_velocity.copy()
    u[d["fixmask"] == 1] = 0.0 if model.initial_displacement is None else u[d["fixmask"] == 1]
    v[d["fixmask"] == 1] = 0.0
    nr = len(model.references)
    r_th = np.array([ref.theta0 for ref in model.references], float)
    r_om = np.array([ref.speed * ramp(0.0, ref.ramp_time) if d["r_mode"][r] == 1 else ref.omega0
                     for r, ref in enumerate(model.references)], float)
    for r in range(nr):
        ids = d["r_nodes"][d["r_ptr"][r]:d["r_ptr"][r + 1]]
        off = d["r_off"][d["r_ptr"][r]:d["r_ptr"][r + 1]]
        c, s = math.cos(r_th[r]), math.sin(r_th[r])
        rx, ry = c * off[:, 0] - s * off[:, 1], s * off[:, 0] + c * off[:, 1]
        u[ids, 0], u[ids, 1] = rx - off[:, 0], ry - off[:, 1]
        v[ids, 0], v[ids, 1] = -r_om[r] * ry, r_om[r] * rx
        if dim == 3:
            u[ids, 2] = 0.0
            v[ids, 2] = 0.0
    r_prev = np.zeros((nr, 7))
    r_prev[:, 3] = r_th
    r_prev[:, 4] = r_th
    r_prev[:, 6] = r_th
    return u, v, r_th, r_om, r_prev


def _open_edges(segs: np.ndarray, g_pair: np.ndarray) -> np.ndarray:
    """Per segment, bit ``e`` set when its border edge ``e`` (nodes ``e``, ``e + 1``; 3D facets) belongs to no
    other segment of the same contact pair: an edge of the master surface. 2D segments get 0."""
    if segs.ndim != 2 or segs.shape[1] != 4 or len(segs) == 0:
        return np.zeros(len(segs), np.int64)
    return ((facet_neighbours(segs, g_pair) < 0) * (1 << np.arange(4))).sum(axis=1).astype(np.int64)


#: loop state saved in a checkpoint (the prepared contact search buffers included: the search only
#: reruns when the contact nodes have moved, so its candidate lists are state too)
_STATE = ("u", "v", "a", "f", "r_pos", "r_vel", "r_acc", "r_th", "r_om", "r_al", "r_prev", "ld_fprev", "ld_uprev",
          "c_usearch", "acc", "head", "nxt", "cand", "ncand", "gap")
_OUT = ("out_t", "out_E", "out_th", "out_om", "out_tq", "out_pos", "out_pu", "out_pv")
CHECKPOINT_FORMAT = "gearrom.explicit-checkpoint/2"
#: format whose key also covers t_end and the chunk count (resumed as the same run only)
_LEGACY_FORMAT = "gearrom.explicit-checkpoint/1"


def _feeder(h):
    """A function that feeds a value (arrays, mappings, sequences, scalars) into the hash ``h``."""
    def feed(value) -> None:
        if isinstance(value, np.ndarray):
            h.update(str((value.dtype.str, value.shape)).encode())
            h.update(np.ascontiguousarray(value).tobytes())
        elif isinstance(value, dict) or hasattr(value, "items"):
            for k in sorted(value):
                h.update(str(k).encode())
                feed(value[k])
        elif isinstance(value, (tuple, list)):
            for x in value:
                feed(x)
        else:
            h.update(repr(value).encode())
        h.update(b"|")
    return feed


def fingerprint(model: ExplicitModel, **settings) -> str:
    """SHA-1 of every field of ``model`` and of the run ``settings``: a checkpoint resumes only the run
    that wrote it."""
    import dataclasses
    import hashlib

    h = hashlib.sha1()
    feed = _feeder(h)
    for fld in dataclasses.fields(model):
        h.update(fld.name.encode())
        feed(getattr(model, fld.name))
    feed(settings)
    return h.hexdigest()


def field_fingerprints(model: ExplicitModel, **settings) -> dict[str, str]:
    """SHA-1 of each field of ``model`` and of each run setting (``setting:<name>``): what a refused
    checkpoint names as differing."""
    import dataclasses
    import hashlib

    out = {}
    items = [(f.name, getattr(model, f.name)) for f in dataclasses.fields(model)]
    items += [(f"setting:{k}", v) for k, v in sorted(settings.items())]
    for name, value in items:
        h = hashlib.sha1()
        _feeder(h)(value)
        out[name] = h.hexdigest()
    return out


def _differing(stored: str, current: dict[str, str]) -> str:
    """Names of the fields whose fingerprints differ between a checkpoint's stored ``fields`` (JSON) and the run."""
    import json

    try:
        old = json.loads(stored)
    except ValueError:
        return "unknown (the checkpoint stores no per-field fingerprints)"
    names = sorted(k for k in set(old) | set(current) if old.get(k) != current.get(k))
    return ", ".join(names) if names else "none by field (the combined key differs)"


def _save_checkpoint(path: Path, state: dict, out: dict, row: int, chunk: int, t0: float, wall: float,
                     key: str, bounds: np.ndarray, fields: str = "{}") -> None:
    from gearrom.fe.cache import atomic_path

    arrays = {f"state_{k}": state[k] for k in _STATE}
    arrays.update({k: out[k][:row] for k in _OUT})
    with atomic_path(path) as tmp:
        np.savez(tmp, format=np.array(CHECKPOINT_FORMAT), key=np.array(key), row=np.array(row),
                 chunk=np.array(chunk), bounds=np.asarray(bounds[:chunk + 1], np.int64), t0=np.array(t0),
                 wall=np.array(wall), fields=np.array(fields), **arrays)


def _load_checkpoint(path: Path, state: dict, out: dict, key: str, legacy_key: str,
                     bounds: np.ndarray, fields: dict | None = None) -> tuple[int, int, float, float, bool]:
    """Restore ``state`` and ``out`` in place from ``path``; return (row, next chunk, t0, wall so far, whether
    the file is of an older format than :data:`CHECKPOINT_FORMAT`).

    A checkpoint continues a run of the same model, step, sample period, probes and thread mode whose
    completed chunk boundaries are the first ones of ``bounds`` (output rows). The end time may differ:
    a run extended to a later ``t_end`` with the same chunk length continues where the stored one stopped.
    """
    try:
        with np.load(path) as z:
            fmt = str(z["format"])
            chunk, row = int(z["chunk"]), int(z["row"])
            if fmt == _LEGACY_FORMAT:
                if str(z["key"]) != legacy_key:
                    raise ConfigError(f"checkpoint {path} was written by a different model or run settings "
                                      "(fingerprint mismatch; this older format resumes only the same t_end "
                                      "and chunks); delete it or run without resume")
            elif fmt != CHECKPOINT_FORMAT:
                raise ConfigError(f"checkpoint {path}: format {fmt!r}, expected {CHECKPOINT_FORMAT!r}")
            else:
                if str(z["key"]) != key:
                    which = _differing(str(z["fields"]) if "fields" in z else "", fields or {})
                    raise ConfigError(f"checkpoint {path} was written by a different model or run settings "
                                      f"(fingerprint mismatch in: {which}); delete it or run without resume")
                done = z["bounds"]
                if chunk >= len(bounds) or not np.array_equal(bounds[:chunk + 1], done):
                    raise ConfigError(
                        f"checkpoint {path} holds {chunk} chunks ending at output row {int(done[-1])}, which are "
                        f"not the first chunks of this run ({len(bounds) - 1} chunks, {int(bounds[-1])} rows): "
                        "a run continues only with the same chunk boundaries and a t_end not before the stored "
                        "one; delete it or run without resume")
            for k in _STATE:
                state[k][...] = z[f"state_{k}"]
            for k in _OUT:
                out[k][:row] = z[k]
            return row, chunk, float(z["t0"]), float(z["wall"]), fmt != CHECKPOINT_FORMAT
    except (OSError, KeyError, ValueError) as exc:
        raise ConfigError(f"checkpoint {path} cannot be read ({exc}); delete it to start over") from None


def _run_meta(model: ExplicitModel, d: dict, step_dt: float, nsteps_total: int, sample_period: float, wall: float,
              parallel: bool) -> dict:
    """The run's metadata: sizes, step, timing, throughput, material, damping, contact counts."""
    n, dim = model.nodes.shape
    return dict(dim=dim, n_nodes=n, n_elements=int(model.elements.shape[0]), dt_s=step_dt,
                dt_stable_s=d["dt_stable"], n_steps=nsteps_total, t_end_s=nsteps_total * step_dt,
                sample_period_s=sample_period, wall_time_s=wall,
                element_updates_per_s=nsteps_total * model.elements.shape[0] / wall,
                relative_damping=model.relative_damping,
                n_passes=int(d["cptr"].size - 1), parallel=parallel, integration=model.integration,
                hourglass_stiffness=model.hourglass_stiffness,
                hourglass_viscosity=model.hourglass_viscosity, mass_damping=model.mass_damping,
                material=dict(E_Pa=model.material.E, nu=model.material.nu, rho_kg_m3=model.material.rho),
                thickness_m=model.thickness, references=[r.nodes for r in model.references],
                added_mass_kg=d["added_mass"], total_mass_kg=float(d["mass"].sum()),
                n_contact_slaves=int(d["slaves"].size), n_contact_segments=int(len(d["segs"])))


def _start_or_resume(model: ExplicitModel, checkpoint: Path | None, resume: bool, st: dict, out: dict,
                     bounds: np.ndarray, run_settings: dict, t_end: float, chunks: int):
    """``(key, fields, row, first chunk, t0, wall so far)`` of a run: its checkpoint key and per-field
    fingerprints (JSON), and where it starts (``st`` and ``out`` filled from the checkpoint on a resume)."""
    if checkpoint is None:
        return "", "{}", 0, 0, 0.0, 0.0
    key = fingerprint(model, **run_settings)
    fields = field_fingerprints(model, **run_settings)
    if not (resume and checkpoint.is_file()):
        return key, json.dumps(fields), 0, 0, 0.0, 0.0
    legacy = fingerprint(model, t_end=t_end, chunks=chunks, **run_settings)
    row, first, t0, wall_before, older = _load_checkpoint(checkpoint, st, out, key, legacy, bounds, fields)
    log.info("explicit: resumed from %s at t = %.4e s (chunk %d of %d)", checkpoint, t0, first, chunks)
    if first == chunks and older:  # a finished run of the older format: stored extendable
        _save_checkpoint(checkpoint, st, out, row, first, t0, wall_before, key, bounds, json.dumps(fields))
    return key, json.dumps(fields), row, first, t0, wall_before


def solve(model: ExplicitModel, t_end: float, sample_period: float | None = None, *,
          dt: float | None = None, safety: float = 0.9, probes=(), chunks: int = 20,
          prepared: dict | None = None, parallel: bool | None = None,
          checkpoint: str | Path | None = None, checkpoint_every: float = 300.0,
          resume: bool = True, wall_limit: float | None = None) -> ExplicitResult:
    """Run the explicit dynamics of ``model`` from t = 0 to ``t_end``.

    Parameters
    ----------
    model : ExplicitModel
    t_end : float
        End time, s.
    sample_period : float, optional
        Output period, s (default: t_end / 200). The time step is lowered slightly so that the
        sample period is an integer number of steps.
    dt : float, optional
        Time step, s; must not exceed the stable step (default: ``safety`` * stable step).
    probes : sequence of int
        Node ids whose displacement/velocity histories are recorded.
    chunks : int
        The run is split into this many compiled calls; progress (time, ETA, energy balance) is logged
        and checkpoints are written between them.
    prepared : dict, optional
        Output of :func:`prepare` for this model, to skip the set-up.
    parallel : bool, optional
        Use the multi-threaded loop (default: when the mesh has >= 20000 elements; below that the
        per-step thread start-up costs more than it saves, and much more on a loaded machine).
    checkpoint : path, optional
        File (``.npz``) that holds the complete loop state at a chunk boundary, written atomically at
        most every ``checkpoint_every`` wall seconds and after the last chunk. With ``resume`` an
        existing checkpoint of the same model and settings is continued from; the resumed run is bit
        for bit the uninterrupted one (same chunks, same thread count). A checkpoint of a shorter run
        with the same chunk length (its chunk boundaries the first ones of this run) is continued to the
        later ``t_end``, bit for bit the run made to that end at once.
    checkpoint_every : float
        Wall time between checkpoints, s.
    resume : bool
        Continue from ``checkpoint`` when it exists (otherwise it is overwritten).
    wall_limit : float, optional
        Wall time of this call, s: once a chunk ends past it, the checkpoint is written and
        :class:`RunInterrupted` raised (a sitting with a fixed end; call again to resume).

    Raises
    ------
    ConfigError
        Bad times or probes, or a checkpoint of another model or settings.
    ModelError
        The run diverged.
    RunInterrupted
        ``wall_limit`` was reached (the checkpoint holds the run so far).
    """
    if wall_limit is not None and checkpoint is None:
        raise ConfigError("wall_limit needs a checkpoint file to resume from")
    if not t_end > 0:
        raise ConfigError(f"t_end must be > 0 s, got {t_end}")
    d = prepared if prepared is not None else prepare(model, safety)
    dt_max = d["dt"]
    if dt is not None:
        if not 0 < dt <= d["dt_stable"]:
            raise ConfigError(f"dt = {dt:.3e} s exceeds the stable step {d['dt_stable']:.3e} s")
        dt_max = dt
    if sample_period is None:
        sample_period = t_end / 200
    if not sample_period > 0:
        raise ConfigError(f"sample_period must be > 0 s, got {sample_period}")
    out_every = max(1, math.ceil(sample_period / dt_max * (1 - 1e-12)))
    step_dt = sample_period / out_every
    if model.relative_damping * step_dt > 0.5:
        raise ConfigError(f"relative_damping {model.relative_damping:g} 1/s is too large for the step "
                          f"{step_dt:.3e} s (alpha dt must stay below 0.5)")
    n_out_total = math.ceil(t_end / sample_period * (1 - 1e-12))
    n, dim = model.nodes.shape
    nr = len(model.references)
    probes = np.asarray(probes, np.int64).reshape(-1)
    if probes.size and (probes.min() < 0 or probes.max() >= n):
        raise ConfigError(f"probes must be node ids in 0..{n - 1}")
    u, v, r_th, r_om, r_prev = _initial_state(model, d)
    st = dict(u=u, v=v, a=np.zeros_like(u), f=np.zeros_like(u), r_pos=np.zeros((nr, dim)),
              r_vel=np.zeros((nr, dim)), r_acc=np.zeros((nr, dim)), r_th=r_th, r_om=r_om, r_al=np.zeros(nr),
              r_prev=r_prev, ld_fprev=np.zeros((d["ld_nodes"].size, dim)),
              ld_uprev=u[d["ld_nodes"]].copy() if d["ld_nodes"].size else np.zeros((0, dim)),
              c_usearch=np.zeros((d["c_nodes"].size, dim)), acc=np.zeros(8),
              head=d["head"], nxt=d["nxt"], cand=d["cand"], ncand=d["ncand"], gap=d["gap"])
    st["acc"][5] = -1.0
    nt = n_out_total + 1
    out = dict(out_t=np.zeros(nt), out_E=np.zeros((nt, NE_OUT)), out_th=np.zeros((nt, nr)),
               out_om=np.zeros((nt, nr)), out_tq=np.zeros((nt, nr)), out_pos=np.zeros((nt, nr, dim)),
               out_pu=np.zeros((nt, probes.size, dim)), out_pv=np.zeros((nt, probes.size, dim)))
    chunks = max(1, min(chunks, n_out_total))
    bounds = np.linspace(0, n_out_total, chunks + 1).round().astype(int)
    if parallel is None:
        parallel = model.elements.shape[0] >= 20000
    run_loop = run_loop_parallel if parallel else run_loop_serial
    if checkpoint is not None:
        checkpoint = Path(checkpoint)
    key, fields, row, first, t0, wall_before = _start_or_resume(
        model, checkpoint, resume, st, out, bounds, dict(sample_period=sample_period, dt=step_dt, probes=probes,
                                                         parallel=bool(parallel)), t_end, chunks)
    # the loop's array groups (the state arrays are updated in place; the output rows change per chunk)
    src = {**d, **st, "X": model.nodes, "probes": probes}
    fixed = tuple(tuple(src[k] for k in names) for names in
                  (STATE_ARRAYS, NODE_ARRAYS, ELEMENT_ARRAYS, LOAD_ARRAYS, REFERENCE_ARRAYS, CONTACT_ARRAYS))
    wall0 = time.perf_counter()
    last_save = wall0
    steps_run = 0
    for c in range(first, chunks):
        n_out = bounds[c + 1] - bounds[c]
        if n_out == 0:
            continue
        nsteps = n_out * out_every
        # chunk 0 writes rows [0, n_out]; a later chunk starts by rewriting the previous last row
        sl = slice(row - 1 if c else 0, None)
        o = {**{k: x[sl] for k, x in out.items()}, "probes": probes}
        written = run_loop(nsteps, step_dt, out_every, t0, model.mass_damping, model.relative_damping,
                           d["margin"], d["cell_h"], *fixed, tuple(o[k] for k in OUTPUT_ARRAYS), st["acc"])
        row = (row - 1 if c else 0) + written
        t0 += nsteps * step_dt
        steps_run += nsteps
        if not np.all(np.isfinite(st["u"])):
            raise ModelError(f"explicit run diverged before t = {t0:.4e} s (non-finite displacement)")
        now = time.perf_counter()
        rate = steps_run / (now - wall0)
        eta = (n_out_total - bounds[c + 1]) * out_every / rate if rate > 0 else float("nan")
        e = out["out_E"][row - 1]
        log.info("explicit: t = %.4e / %.4e s (%.1f %%), wall %.0f s, ETA %.0f s, energy balance error %.3g J "
                 "(strain + contact %.3g J, external work %.3g J)", t0, t_end, 100.0 * bounds[c + 1] / n_out_total,
                 wall_before + now - wall0, eta, e[9], e[1] + e[2] + e[4], e[8])
        if checkpoint is not None and (now - last_save >= checkpoint_every or c == chunks - 1):
            _save_checkpoint(checkpoint, st, out, row, c + 1, t0, wall_before + now - wall0, key, bounds, fields)
            last_save = time.perf_counter()
        if wall_limit is not None and now - wall0 >= wall_limit and c < chunks - 1:
            _save_checkpoint(checkpoint, st, out, row, c + 1, t0, wall_before + now - wall0, key, bounds, fields)
            raise RunInterrupted(f"explicit run stopped at t = {t0:.4e} of {t_end:.4e} s (wall limit "
                                 f"{wall_limit:g} s); checkpoint {checkpoint}: run again to resume")
    wall = wall_before + time.perf_counter() - wall0
    nsteps_total = n_out_total * out_every
    u, v = st["u"], st["v"]
    out_t, out_E, out_th, out_om, out_tq, out_pos, out_pu, out_pv = (out[k] for k in _OUT)
    meta = _run_meta(model, d, step_dt, nsteps_total, sample_period, wall, bool(parallel))
    return ExplicitResult(t=out_t[:row], energies=out_E[:row], theta=out_th[:row], omega=out_om[:row],
                          torque_body=out_tq[:row], ref_disp=out_pos[:row], probe_ids=probes,
                          probe_u=out_pu[:row], probe_v=out_pv[:row], u_final=u, v_final=v, meta=meta)
