"""The compiled time loop: central differences in velocity-Verlet form, all inside one numba function.

Per step (Belytschko, Liu & Moran, Nonlinear FE, box 6.1, with velocities also at full steps):

    v^{n+1/2} = v^n + dt/2 a^n ;  u^{n+1} = u^n + dt v^{n+1/2} ;  rigid references likewise, then the
    tied nodes follow their reference exactly ;  f^{n+1} = f(u^{n+1}, v^{n+1/2}) (elements in
    parallel by pass, contact, loads, damping) ;  a^{n+1} = f / m ;  v^{n+1} = v^{n+1/2} + dt/2 a^{n+1}.

A rigid reference (centre = the gear axis; its offset from the centre of mass of the tied nodes is
neglected in the translation-rotation coupling) has generalized forces Q_c = sum f_i, Q_theta = sum (x_i - c) x f_i |_z plus external torque and
springs, mass M = sum m_i + m_extra and inertia J = sum m_i |r_i,perp|^2 + J_extra.

Energies (columns of ``out_E``): 0 kinetic, 1 internal, 2 hourglass (stiffness), 3 hourglass viscous
dissipation, 4 contact penalty, 5 friction dissipation, 6 damping dissipation (mass and relative
damping, spring and bearing dampers), 7 spring potential (reference springs, bearings), 8 external work (loads,
torques, prescribed-rotation reactions, drivers), 9 balance error sum(0..7) - 8 - E(t=0).
"""
from __future__ import annotations

import hashlib
import math
import types
from pathlib import Path

import numpy as np
from numba import njit, prange

from gearrom.fe.explicit.contact import (contact_forces_2d, contact_scatter_3d, contact_search, contact_slave_3d,
                                         open_edge_allowance)
from gearrom.fe.explicit.kernels import hex8_element, hex8_full_element, q4_element, q4_full_element

NE_OUT = 10
#: node ranges of the free-node pass (fixed, so that its sums are the same on any number of threads)
NPART = 64


@njit(cache=True, inline="always")
def ramp(t, T):
    """Cosine ramp 0 -> 1 over [0, T] (1 for T <= 0)."""
    if T <= 0.0 or t >= T:
        return 1.0
    return 0.5 * (1.0 - math.cos(math.pi * t / T))


@njit(cache=True, inline="always")
def ramp_integral(t, T):
    """Integral of :func:`ramp` from 0 to t, s."""
    if T <= 0.0:
        return t
    if t >= T:
        return 0.5 * T + (t - T)
    return 0.5 * t - 0.5 * T / math.pi * math.sin(math.pi * t / T)


@njit(cache=True, inline="always")
def ramp_rate(t, T):
    """Time derivative of :func:`ramp`, 1/s."""
    if T <= 0.0 or t >= T:
        return 0.0
    return 0.5 * math.pi / T * math.sin(math.pi * t / T)


@njit(cache=True)
def _table(t, times, vals, npts):
    if t <= times[0]:
        return vals[0]
    for k in range(1, npts):
        if t <= times[k]:
            w = (t - times[k - 1]) / (times[k] - times[k - 1])
            return (1.0 - w) * vals[k - 1] + w * vals[k]
    return vals[npts - 1]


#: names of the arrays in each argument group of the loop, in order (the driver packs them by these names
#: from its prepared model ``d``, the run state ``st`` and the output rows ``o``)
NODE_ARRAYS = ("X", "mass", "kind", "fixmask", "body", "r_center", "r_fd")
ELEMENT_ARRAYS = ("conn", "B", "V0", "gamma", "khg", "chg", "lam", "mu", "cptr", "bptr", "full", "Bg", "Wg",
                  "gshape", "grot")
LOAD_ARRAYS = ("ld_nodes", "ld_ptr", "ld_force", "ld_t", "ld_val", "ld_npts", "ld_fprev", "ld_uprev")
REFERENCE_ARRAYS = ("r_nodes", "r_ptr", "r_off", "r_M", "r_J", "r_mode", "r_speed", "r_ramp", "r_torque",
                    "r_tramp", "r_k", "r_c", "r_fixtr", "r_kb", "r_cb", "r_pos", "r_vel", "r_acc", "r_th",
                    "r_om", "r_al", "r_prev")
CONTACT_ARRAYS = ("slaves", "s_pair", "segs", "g_pair", "g_k", "g_rad", "p_mu", "p_vreg", "p_depth", "head",
                  "nxt", "cand", "ncand", "gap", "seg_open", "seg_sag", "c_nodes", "c_usearch")
STATE_ARRAYS = ("u", "v", "a", "f")
OUTPUT_ARRAYS = ("out_t", "out_E", "out_th", "out_om", "out_tq", "out_pos", "probes", "out_pu", "out_pv")


def _run_loop(nsteps, dt, out_every, t0, alpha, alpha_r, margin, cell_h,
              state, nodes, elements, loads, refs, contact, outputs, acc):
    """Advance the model ``nsteps`` steps of ``dt`` from time ``t0``; state arrays are updated in place.

    ``alpha``: mass damping [1/s]; ``alpha_r``: relative damping [1/s]; ``margin``, ``cell_h``: contact
    search margin and cell size [m]. The array groups are tuples in the order of :data:`STATE_ARRAYS`,
    :data:`NODE_ARRAYS`, :data:`ELEMENT_ARRAYS`, :data:`LOAD_ARRAYS`, :data:`REFERENCE_ARRAYS`,
    :data:`CONTACT_ARRAYS` and :data:`OUTPUT_ARRAYS`.
    ``acc`` (8,) carries the accumulated dissipations/work and E(t=0) between calls:
    [hg visc, friction, damping, external work, E0, last sampled output index, W_int, W_hg].
    Returns the number of output rows written.
    """
    u, v, a, f = state
    X, mass, kind, fixmask, body, r_center, r_fd = nodes
    conn, B, V0, gamma, khg, chg, lam, mu, cptr, bptr, full, Bg, Wg, gshape, grot = elements
    ld_nodes, ld_ptr, ld_force, ld_t, ld_val, ld_npts, ld_fprev, ld_uprev = loads
    (r_nodes, r_ptr, r_off, r_M, r_J, r_mode, r_speed, r_ramp, r_torque, r_tramp, r_k, r_c, r_fixtr, r_kb, r_cb,
     r_pos, r_vel, r_acc, r_th, r_om, r_al, r_prev) = refs
    (slaves, s_pair, segs, g_pair, g_k, g_rad, p_mu, p_vreg, p_depth, head, nxt, cand, ncand, gap, seg_open,
     seg_sag, c_nodes, c_usearch) = contact
    out_t, out_E, out_th, out_om, out_tq, out_pos, probes, out_pu, out_pv = outputs
    n, dim = u.shape
    nr = r_M.shape[0]
    ncol = cptr.shape[0] - 1
    nout = 0
    wint = 0.0
    whg = 0.0
    epen = 0.0
    # 3D contact: scratch and per-slave results of the parallel pass (contact_slave_3d)
    ns = slaves.shape[0] if dim == 3 else 0
    c_lb = np.empty((ns, cand.shape[1]))
    c_ord = np.empty((ns, cand.shape[1]), np.int64)
    c_out = np.empty((ns, 9))
    c_act = np.empty(ns, np.int64)
    allowance = open_edge_allowance(g_rad, seg_sag) if dim == 3 else 0.0
    # per node range: the references' damping reactions and the dissipated powers of the free-node pass
    part = np.empty((NPART, nr, 4))
    part_p = np.empty((NPART, 2))
    for step in range(nsteps + 1):
        t = t0 + step * dt
        if step > 0:
            # ---- kick (half) + drift of free nodes; the forces cleared in the same pass
            for i in prange(n):
                if kind[i] < 0:
                    for d in range(dim):
                        if fixmask[i, d]:
                            v[i, d] = 0.0
                        else:
                            v[i, d] += 0.5 * dt * a[i, d]
                            u[i, d] += dt * v[i, d]
                for d in range(dim):
                    f[i, d] = 0.0
            # ---- rigid references: kick + drift, then tied nodes follow
            for r in range(nr):
                if r_fixtr[r] == 0:
                    for d in range(dim):
                        r_vel[r, d] += 0.5 * dt * r_acc[r, d]
                        r_pos[r, d] += dt * r_vel[r, d]
                th_old = r_th[r]
                if r_mode[r] == 1:
                    r_th[r] = r_prev[r, 3] + r_speed[r] * ramp_integral(t, r_ramp[r])
                    r_om[r] = (r_th[r] - th_old) / dt
                else:
                    r_om[r] += 0.5 * dt * r_al[r]
                    r_th[r] += dt * r_om[r]
                dth = r_th[r] - th_old
                # external work of torque / prescribed reaction / driver: first half of trapezoid
                acc[3] += 0.5 * r_prev[r, 0] * dth + 0.5 * r_prev[r, 2] * dth
                cth = math.cos(r_th[r]); sth = math.sin(r_th[r])
                w = r_om[r]
                for k in range(r_ptr[r], r_ptr[r + 1]):
                    i = r_nodes[k]
                    rx = cth * r_off[k, 0] - sth * r_off[k, 1]
                    ry = sth * r_off[k, 0] + cth * r_off[k, 1]
                    u[i, 0] = r_pos[r, 0] + rx - r_off[k, 0]
                    u[i, 1] = r_pos[r, 1] + ry - r_off[k, 1]
                    v[i, 0] = r_vel[r, 0] - w * ry
                    v[i, 1] = r_vel[r, 1] + w * rx
                    if dim == 3:
                        u[i, 2] = r_pos[r, 2]
                        v[i, 2] = r_vel[r, 2]
        else:
            for i in prange(n):
                for d in range(dim):
                    f[i, d] = 0.0
        # ---- contact search when contact nodes moved too far
        if slaves.shape[0] > 0:
            dmax = 0.0
            for k in range(c_nodes.shape[0]):
                i = c_nodes[k]
                s2 = 0.0
                for d in range(dim):
                    dd = u[i, d] - c_usearch[k, d]
                    s2 += dd * dd
                dmax = max(dmax, s2)
            if step == 0 or math.sqrt(dmax) > 0.5 * margin:
                for k in range(c_nodes.shape[0]):
                    i = c_nodes[k]
                    for d in range(dim):
                        c_usearch[k, d] = u[i, d]
                        a[i, d] = X[i, d] + u[i, d]
                contact_search(a, slaves, s_pair, segs, g_pair, g_rad,
                               margin + p_depth.max(), head, nxt, cand, ncand, cell_h)
        # ---- forces (cleared above)
        wint = 0.0
        whg = 0.0
        phg = 0.0
        for c in range(ncol):
            # the blocks of one pass share no node (geometry.schedule_elements); each runs in sequence
            for b in prange(cptr[c], cptr[c + 1]):
                for e in range(bptr[b], bptr[b + 1]):
                    if full[e]:
                        if dim == 2:
                            wint += q4_full_element(e, conn, u, Bg, Wg, gshape, grot, lam, mu, f)
                        else:
                            wint += hex8_full_element(e, conn, u, Bg, Wg, gshape, grot, lam, mu, f)
                    else:
                        if dim == 2:
                            r0, r1, r2 = q4_element(e, conn, u, v, B, V0, gamma, khg, chg, lam, mu, f)
                        else:
                            r0, r1, r2 = hex8_element(e, conn, u, v, B, V0, gamma, khg, chg, lam, mu, f)
                        wint += r0
                        whg += r1
                        phg += r2
        if step > 0:
            acc[0] += phg * dt
        epen = 0.0
        pfr = 0.0
        if slaves.shape[0] > 0:
            # contact works on current positions x = X + u of the contact nodes (slaves and facet nodes), held
            # in ``a`` until the accelerations are formed
            for k in prange(c_nodes.shape[0]):
                i = c_nodes[k]
                for d in range(dim):
                    a[i, d] = X[i, d] + u[i, d]
            if dim == 2:
                epen, pfr = contact_forces_2d(a, v, slaves, s_pair, segs, g_k, cand, ncand,
                                              p_mu, p_vreg, p_depth, f, gap)
            else:
                # the slaves with candidates (an even share per thread), each one's contact in parallel, then
                # the forces added serially (shared master nodes)
                nact = 0
                for i in range(ns):
                    if ncand[i] > 0:
                        c_act[nact] = i
                        nact += 1
                    else:
                        c_out[i, 0] = -1.0
                for q in prange(nact):
                    contact_slave_3d(a, v, slaves, s_pair, segs, g_k, g_rad, cand, ncand, p_mu, p_vreg, p_depth,
                                     seg_open, seg_sag, allowance, c_act[q], c_lb, c_ord, c_out)
                epen, pfr = contact_scatter_3d(slaves, segs, c_out, f, gap)
        if step > 0:
            acc[1] += pfr * dt
        # ---- nodal loads (trapezoidal work)
        for l in range(ld_ptr.shape[0] - 1):
            fac = _table(t, ld_t[l], ld_val[l], ld_npts[l])
            for k in range(ld_ptr[l], ld_ptr[l + 1]):
                i = ld_nodes[k]
                for d in range(dim):
                    fl = fac * ld_force[l, d]
                    f[i, d] += fl
                    acc[3] += 0.5 * (fl + ld_fprev[k, d]) * (u[i, d] - ld_uprev[k, d])
                    ld_fprev[k, d] = fl
                    ld_uprev[k, d] = u[i, d]
        # ---- free nodes, one pass: relative damping, a dashpot m alpha_r from each free node to the rigid
        # frame of its body's reference (velocity relative to that frame); mass damping; acceleration; second
        # half kick. The pass runs over fixed node ranges, each summing its share of the references'
        # reactions (force x, y, z and torque about the axis) and of the dissipated power in its own row of
        # ``part``, so the sums do not depend on the thread count; they are added up in range order below.
        damped = alpha_r > 0.0
        for q in prange(NPART):
            for rb in range(nr):
                for d in range(4):
                    part[q, rb, d] = 0.0
            pdr_q = 0.0
            pd_q = 0.0
            for i in range(q * n // NPART, (q + 1) * n // NPART):
                if kind[i] < 0:
                    rb = body[i]
                    if damped and rb >= 0:
                        px = X[i, 0] + u[i, 0] - r_center[rb, 0] - r_pos[rb, 0]
                        py = X[i, 1] + u[i, 1] - r_center[rb, 1] - r_pos[rb, 1]
                        w = r_om[rb]
                        cm = alpha_r * mass[i]
                        fx = 0.0 if fixmask[i, 0] else -cm * (v[i, 0] - r_vel[rb, 0] + w * py)
                        fy = 0.0 if fixmask[i, 1] else -cm * (v[i, 1] - r_vel[rb, 1] - w * px)
                        f[i, 0] += fx
                        f[i, 1] += fy
                        pdr_q += (fx * fx + fy * fy) / cm
                        part[q, rb, 0] -= fx
                        part[q, rb, 1] -= fy
                        part[q, rb, 3] -= px * fy - py * fx
                        if dim == 3:
                            fz = 0.0 if fixmask[i, 2] else -cm * (v[i, 2] - r_vel[rb, 2])
                            f[i, 2] += fz
                            pdr_q += fz * fz / cm
                            part[q, rb, 2] -= fz
                    for d in range(dim):
                        if fixmask[i, d]:
                            a[i, d] = 0.0
                            v[i, d] = 0.0
                        else:
                            fd = -alpha * mass[i] * v[i, d]
                            pd_q += -fd * v[i, d]
                            a[i, d] = (f[i, d] + fd) / mass[i]
                            if step > 0:
                                v[i, d] += 0.5 * dt * a[i, d]
                else:
                    for d in range(dim):
                        a[i, d] = 0.0
            part_p[q, 0] = pdr_q
            part_p[q, 1] = pd_q
        pdr = 0.0
        pd = 0.0
        for r in range(nr):
            for d in range(4):
                r_fd[r, d] = 0.0
        for q in range(NPART):
            pdr += part_p[q, 0]
            pd += part_p[q, 1]
            for r in range(nr):
                for d in range(4):
                    r_fd[r, d] += part[q, r, d]
        if step > 0:
            acc[2] += (pdr + pd) * dt
        # ---- rigid references
        espring = 0.0
        for r in range(nr):
            qx = 0.0; qy = 0.0; qz = 0.0; qt = 0.0
            cth = math.cos(r_th[r]); sth = math.sin(r_th[r])
            for k in range(r_ptr[r], r_ptr[r + 1]):
                i = r_nodes[k]
                rx = cth * r_off[k, 0] - sth * r_off[k, 1]
                ry = sth * r_off[k, 0] + cth * r_off[k, 1]
                qx += f[i, 0]; qy += f[i, 1]
                if dim == 3:
                    qz += f[i, 2]
                qt += rx * f[i, 1] - ry * f[i, 0]
            qx += r_fd[r, 0]; qy += r_fd[r, 1]; qz += r_fd[r, 2]; qt += r_fd[r, 3]
            out_tq_r = qt
            text = r_torque[r] * ramp(t, r_tramp[r])
            tsp = 0.0
            if r_k[r] > 0.0 or r_c[r] > 0.0:
                thd = 0.0
                omd = 0.0
                if r_mode[r] == 2:
                    thd = r_prev[r, 4] + r_speed[r] * ramp_integral(t, r_ramp[r])
                    omd = r_speed[r] * ramp(t, r_ramp[r])
                tsp = -r_k[r] * (r_th[r] - thd) - r_c[r] * (r_om[r] - omd)
                espring += 0.5 * r_k[r] * (r_th[r] - thd) ** 2
                if step > 0:
                    acc[2] += r_c[r] * (r_om[r] - omd) ** 2 * dt
                if r_mode[r] == 2:
                    # driver work tau_s dtheta_d (trapezoid)
                    dthd = r_speed[r] * (ramp_integral(t, r_ramp[r]) - ramp_integral(t - dt, r_ramp[r]))
                    if step > 0:
                        acc[3] += 0.5 * (tsp + r_prev[r, 5]) * dthd
                    r_prev[r, 5] = tsp
            if r_mode[r] == 1:
                al = r_speed[r] * ramp_rate(t, r_ramp[r])
                treac = r_J[r] * al - qt - text - tsp
                r_al[r] = al
                r_om[r] = r_speed[r] * ramp(t, r_ramp[r])
                r_prev[r, 2] = treac
            else:
                r_al[r] = (qt + text + tsp) / r_J[r]
                if step > 0:
                    r_om[r] += 0.5 * dt * r_al[r]
                r_prev[r, 2] = 0.0
            dth_last = r_th[r] - r_prev[r, 6]
            r_prev[r, 6] = r_th[r]
            if step > 0:
                acc[3] += 0.5 * text * dth_last + 0.5 * r_prev[r, 2] * dth_last
            r_prev[r, 0] = text
            r_prev[r, 1] = out_tq_r
            if r_fixtr[r] == 0:
                q = (qx, qy, qz)
                for d in range(dim):
                    fb = -r_kb[r] * r_pos[r, d] - r_cb[r] * r_vel[r, d]
                    espring += 0.5 * r_kb[r] * r_pos[r, d] ** 2
                    if step > 0:
                        acc[2] += r_cb[r] * r_vel[r, d] ** 2 * dt
                    r_acc[r, d] = (q[d] + fb) / r_M[r]
                    if step > 0:
                        r_vel[r, d] += 0.5 * dt * r_acc[r, d]
            cth = math.cos(r_th[r]); sth = math.sin(r_th[r])
            w = r_om[r]
            for k in range(r_ptr[r], r_ptr[r + 1]):
                i = r_nodes[k]
                rx = cth * r_off[k, 0] - sth * r_off[k, 1]
                ry = sth * r_off[k, 0] + cth * r_off[k, 1]
                v[i, 0] = r_vel[r, 0] - w * ry
                v[i, 1] = r_vel[r, 1] + w * rx
                if dim == 3:
                    v[i, 2] = r_vel[r, 2]
        # ---- output
        if step % out_every == 0 and nout < out_t.shape[0]:
            ke = 0.0
            for i in prange(n):
                if kind[i] < 0:
                    s2 = 0.0
                    for d in range(dim):
                        s2 += v[i, d] * v[i, d]
                    ke += 0.5 * mass[i] * s2
            for r in range(nr):
                s2 = 0.0
                for d in range(dim):
                    s2 += r_vel[r, d] ** 2
                ke += 0.5 * r_M[r] * s2 + 0.5 * r_J[r] * r_om[r] ** 2
            row = nout
            out_t[row] = t
            out_E[row, 0] = ke
            out_E[row, 1] = wint
            out_E[row, 2] = whg
            out_E[row, 3] = acc[0]
            out_E[row, 4] = epen
            out_E[row, 5] = acc[1]
            out_E[row, 6] = acc[2]
            out_E[row, 7] = espring
            out_E[row, 8] = acc[3]
            tot = ke + wint + whg + acc[0] + epen + acc[1] + acc[2] + espring
            if acc[5] < 0.0:
                acc[4] = tot
                acc[5] = 0.0
            out_E[row, 9] = tot - acc[3] - acc[4]
            for r in range(nr):
                out_th[row, r] = r_th[r]
                out_om[row, r] = r_om[r]
                out_tq[row, r] = r_prev[r, 1]
                for d in range(dim):
                    out_pos[row, r, d] = r_pos[r, d]
            for p in range(probes.shape[0]):
                for d in range(dim):
                    out_pu[row, p, d] = u[probes[p], d]
                    out_pv[row, p, d] = v[probes[p], d]
            nout += 1
    acc[6] = wint
    acc[7] = whg
    return nout


def _drop_stale_cache() -> None:
    """Delete cached loop binaries when a module the loop inlines has changed.

    numba's on-disk cache only checks the time stamp of the file defining the cached function
    (this one), not of the kernels/contact modules compiled into it; a hash of those sources is
    kept next to the cache and a mismatch removes the stale ``loop.run_loop_*`` entries.
    """
    here = Path(__file__).resolve().parent
    cache = here / "__pycache__"
    try:
        digest = hashlib.sha1(b"".join((here / f).read_bytes()
                                       for f in ("kernels.py", "contact.py", "loop.py"))).hexdigest()
        stamp = cache / "explicit_loop.sha1"
        if stamp.is_file() and stamp.read_text() == digest:
            return
        for old in cache.glob("loop.run_loop_*.nb[ic]"):
            old.unlink()
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:     # read-only install: numba then falls back to its own cache locator
        pass


_drop_stale_cache()


def _compiled(name: str, parallel: bool):
    fn = types.FunctionType(_run_loop.__code__, _run_loop.__globals__, name, _run_loop.__defaults__)
    fn.__qualname__ = name
    fn.__doc__ = _run_loop.__doc__
    return njit(cache=True, parallel=parallel, fastmath=True)(fn)


#: the loop with prange over nodes and over the element blocks of each pass (large meshes)
run_loop_parallel = _compiled("run_loop_parallel", True)
#: the same loop compiled serially (small meshes: no per-step thread start-up cost)
run_loop_serial = _compiled("run_loop_serial", False)
