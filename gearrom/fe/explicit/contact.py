"""Node-to-segment penalty contact (2D: node to edge, 3D: node to bilinear quad facet).

Search: the segment centroids are binned into a uniform cell grid covering only the overlap of the
slave-node and master-segment bounding boxes (enlarged by one cell), so nodes far from the contact
zone are skipped at once. A slave keeps up to ``K`` candidate segments of its own contact pair whose
centroid lies within (segment radius + margin). The search is repeated when a contact node has moved
by more than (margin - capture depth) / 2 since the last search, so no pair can be missed.

Force (2D): the closest feature of the master polyline (clamped projection on the candidate edges)
gives the signed distance g, continuous as a node slides over master corners, so the penalty force is
the gradient of a continuous potential and creates no energy (an earlier rule, the least penetration
among edges with the projection inside, took a node lying just outside a tooth tip land as deep inside
the flank and kicked it: 0.4 J out of nothing per event). For 0 < -g <= capture depth the slave gets
f = k (-g) n (n the outward master normal, or the direction to the master corner in a vertex zone), the
master nodes get -f times their shape functions at the projection. 3D: among a slave's candidate
facets that have it inside or in their strip beyond an open surface edge, the one whose own gap
(:func:`_facet_gap`: distance to the facet's surface, beyond an open edge to its extension) is the
smallest in magnitude, so that the gap is continuous where the choice changes; above a convex edge, where
no facet has it inside, the nearest border zone (:func:`_signed_gap_3d`). Coulomb friction is regularized by the slip
velocity: f_t = -mu f_n v_t / sqrt(|v_t|^2 + v_reg^2). The penalty energy k g^2 / 2 and the friction
power are returned for the energy balance.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: a projection may fall this fraction of the segment length beyond its ends (so that a slave node
#: sitting exactly on a master corner node does not flicker in and out of contact)
SEG_TOL = 0.02
#: revision of the contact rule per dimension (2: node to edge, 3: node to facet): a stored static start state
#: (:func:`gearrom.fe.explicit.gearpair.stored_start_state`) is reused only with the rule it was solved with
CONTACT_REVISION = {2: "2d-1", 3: "3d-3"}
#: 3D: a node may lie this fraction of the facet radius beyond an edge of the master surface (see
#: :func:`contact_forces_3d`) and still take the facet plane as its contact surface
OPEN_TOL = 0.05


@njit(cache=True)
def contact_search(x, slaves, s_pair, segs, g_pair, g_rad, margin, head, nxt, cand, ncand, cell_h):
    """Fill ``cand``/``ncand`` (candidate segments per slave) from current positions ``x``."""
    dim = x.shape[1]
    ns = slaves.shape[0]
    nseg, nsn = segs.shape
    K = cand.shape[1]
    for i in range(ns):
        ncand[i] = 0
    if ns == 0 or nseg == 0:
        return
    lo = np.empty(3)
    hi = np.empty(3)
    mlo = np.empty(3)
    mhi = np.empty(3)
    cen = np.zeros((nseg, 3))
    for d in range(3):
        lo[d] = 1e300; hi[d] = -1e300; mlo[d] = 1e300; mhi[d] = -1e300
    for i in range(ns):
        for d in range(dim):
            c = x[slaves[i], d]
            lo[d] = min(lo[d], c); hi[d] = max(hi[d], c)
    for s in range(nseg):
        for d in range(dim):
            c = 0.0
            for a in range(nsn):
                c += x[segs[s, a], d]
            c /= nsn
            cen[s, d] = c
            mlo[d] = min(mlo[d], c); mhi[d] = max(mhi[d], c)
    h = cell_h
    for d in range(dim):
        lo[d] = max(lo[d], mlo[d]) - 2 * h
        hi[d] = min(hi[d], mhi[d]) + 2 * h
        if hi[d] < lo[d]:
            return  # bounding boxes do not overlap: no candidate anywhere
    maxcells = head.shape[0]
    while True:
        nc = 1
        for d in range(dim):
            nc *= int((hi[d] - lo[d]) / h) + 1
        if nc <= maxcells:
            break
        h *= 1.5
    nx = int((hi[0] - lo[0]) / h) + 1
    ny = int((hi[1] - lo[1]) / h) + 1
    nz = int((hi[2] - lo[2]) / h) + 1 if dim == 3 else 1
    for c in range(nx * ny * nz):
        head[c] = -1
    for s in range(nseg):
        ix = int((cen[s, 0] - lo[0]) / h)
        iy = int((cen[s, 1] - lo[1]) / h)
        iz = int((cen[s, 2] - lo[2]) / h) if dim == 3 else 0
        if ix < 0 or iy < 0 or iz < 0 or ix >= nx or iy >= ny or iz >= nz:
            nxt[s] = -2
            continue
        c = (iz * ny + iy) * nx + ix
        nxt[s] = head[c]
        head[c] = s
    dist = np.empty(K)
    for i in range(ns):
        n = slaves[i]
        px = x[n, 0]; py = x[n, 1]
        pz = x[n, 2] if dim == 3 else 0.0
        ix = int(math.floor((px - lo[0]) / h))
        iy = int(math.floor((py - lo[1]) / h))
        iz = int(math.floor((pz - lo[2]) / h)) if dim == 3 else 0
        if ix < -1 or iy < -1 or iz < -1 or ix > nx or iy > ny or iz > nz:
            continue
        zr = 1 if dim == 3 else 0
        for kz in range(iz - zr, iz + zr + 1):
            if kz < 0 or kz >= nz:
                continue
            for ky in range(iy - 1, iy + 2):
                if ky < 0 or ky >= ny:
                    continue
                for kx in range(ix - 1, ix + 2):
                    if kx < 0 or kx >= nx:
                        continue
                    s = head[(kz * ny + ky) * nx + kx]
                    while s >= 0:
                        if g_pair[s] == s_pair[i]:
                            own = False
                            for a in range(nsn):
                                if segs[s, a] == n:
                                    own = True
                            if not own:
                                dx = px - cen[s, 0]; dy = py - cen[s, 1]
                                dz = pz - cen[s, 2] if dim == 3 else 0.0
                                r = math.sqrt(dx * dx + dy * dy + dz * dz)
                                if r <= g_rad[s] + margin:
                                    m = ncand[i]
                                    if m < K:
                                        cand[i, m] = s; dist[m] = r; ncand[i] = m + 1
                                    else:
                                        worst = 0
                                        for q in range(1, K):
                                            if dist[q] > dist[worst]:
                                                worst = q
                                        if r < dist[worst]:
                                            cand[i, worst] = s; dist[worst] = r
                        s = nxt[s]


@njit(cache=True, fastmath=True)
def contact_forces_2d(x, v, slaves, s_pair, segs, g_k, cand, ncand, p_mu, p_vreg, p_depth, f, gap):
    """Add 2D node-to-edge penalty/friction forces to ``f``; return (penalty energy, friction power).

    ``gap`` (ns,) receives the gap of each slave (0 when not in contact, negative = penetration).
    """
    epot = 0.0
    pfric = 0.0
    for i in range(slaves.shape[0]):
        gap[i] = 0.0
        if ncand[i] == 0:
            continue
        n = slaves[i]
        p = s_pair[i]
        depth = p_depth[p]
        # closest feature of the master polyline (clamped projection): the signed distance to a
        # polyline is continuous, so the penalty force is the gradient of a continuous potential
        # (no energy created when a node slides over a master corner)
        best = -1
        bd = 0.0
        bxi = 0.0
        for m in range(ncand[i]):
            s = cand[i, m]
            a = segs[s, 0]; b = segs[s, 1]
            tx = x[b, 0] - x[a, 0]; ty = x[b, 1] - x[a, 1]
            L2 = tx * tx + ty * ty
            rx = x[n, 0] - x[a, 0]; ry = x[n, 1] - x[a, 1]
            xi = min(max((rx * tx + ry * ty) / L2, 0.0), 1.0)
            dx = rx - xi * tx; dy = ry - xi * ty
            d = math.sqrt(dx * dx + dy * dy)
            if best < 0 or d < bd - 1e-12 * math.sqrt(L2) or (d <= bd + 1e-12 * math.sqrt(L2) and 0.0 < xi < 1.0):
                best = s; bd = d; bxi = xi
        if best < 0:
            continue
        a = segs[best, 0]; b = segs[best, 1]
        tx = x[b, 0] - x[a, 0]; ty = x[b, 1] - x[a, 1]
        L = math.sqrt(tx * tx + ty * ty)
        nx = ty / L; ny = -tx / L
        rx = x[n, 0] - x[a, 0] - bxi * tx; ry = x[n, 1] - x[a, 1] - bxi * ty
        sgn = rx * nx + ry * ny
        if sgn >= 0.0 or bd >= depth:
            continue  # outside the master body, or deeper than the capture depth
        bg = -bd
        if 0.0 < bxi < 1.0 or bd <= 1e-9 * L:
            pass     # inside the segment's normal zone: n is the segment normal
        else:
            nx = -rx / bd; ny = -ry / bd   # vertex zone: along the line to the master corner
        k = g_k[best]
        fn = -k * bg
        gap[i] = bg
        epot += 0.5 * k * bg * bg
        fx = fn * nx; fy = fn * ny
        mu = p_mu[p]
        if mu > 0.0:
            w0 = 1.0 - bxi
            vx = v[n, 0] - w0 * v[a, 0] - bxi * v[b, 0]
            vy = v[n, 1] - w0 * v[a, 1] - bxi * v[b, 1]
            vn = vx * nx + vy * ny
            vtx = vx - vn * nx; vty = vy - vn * ny
            sc = mu * fn / math.sqrt(vtx * vtx + vty * vty + p_vreg[p] * p_vreg[p])
            fx -= sc * vtx; fy -= sc * vty
            pfric += sc * (vtx * vtx + vty * vty)
        f[n, 0] += fx; f[n, 1] += fy
        f[a, 0] -= (1.0 - bxi) * fx; f[a, 1] -= (1.0 - bxi) * fy
        f[b, 0] -= bxi * fx; f[b, 1] -= bxi * fy
    return epot, pfric


@njit(cache=True, fastmath=True, inline="always")
def _facet_point(x, segs, s, xi, eta):
    """Point, tangents d/dxi, d/deta of bilinear facet ``s`` at (xi, eta)."""
    sx = (-1.0, 1.0, 1.0, -1.0)
    sy = (-1.0, -1.0, 1.0, 1.0)
    p0 = 0.0; p1 = 0.0; p2 = 0.0
    a0 = 0.0; a1 = 0.0; a2 = 0.0
    c0 = 0.0; c1 = 0.0; c2 = 0.0
    for q in range(4):
        nd = segs[s, q]
        w = 0.25 * (1 + sx[q] * xi) * (1 + sy[q] * eta)
        wx = 0.25 * sx[q] * (1 + sy[q] * eta)
        wy = 0.25 * sy[q] * (1 + sx[q] * xi)
        p0 += w * x[nd, 0]; p1 += w * x[nd, 1]; p2 += w * x[nd, 2]
        a0 += wx * x[nd, 0]; a1 += wx * x[nd, 1]; a2 += wx * x[nd, 2]
        c0 += wy * x[nd, 0]; c1 += wy * x[nd, 1]; c2 += wy * x[nd, 2]
    return p0, p1, p2, a0, a1, a2, c0, c1, c2


@njit(cache=True, fastmath=True, inline="always")
def _edge_closest(x, n, pa, pb):
    """Closest point of the straight segment from node ``pa`` to node ``pb`` to node ``n``: (t, distance^2)."""
    t0 = x[pb, 0] - x[pa, 0]; t1 = x[pb, 1] - x[pa, 1]; t2 = x[pb, 2] - x[pa, 2]
    r0 = x[n, 0] - x[pa, 0]; r1 = x[n, 1] - x[pa, 1]; r2 = x[n, 2] - x[pa, 2]
    L2 = t0 * t0 + t1 * t1 + t2 * t2
    t = min(max((r0 * t0 + r1 * t1 + r2 * t2) / L2, 0.0), 1.0)
    d0 = r0 - t * t0; d1 = r1 - t * t1; d2 = r2 - t * t2
    return t, d0 * d0 + d1 * d1 + d2 * d2


@njit(cache=True, fastmath=True)
def facet_closest(x, segs, s, n):
    """Closest point of bilinear facet ``s`` to node ``n``: (xi, eta, distance, inside_zone, beyond, xi_u, eta_u).

    Newton on the unconstrained projection; if it falls outside [-1, 1]^2 the closest point is on the
    border, whose four edges are straight segments (bilinear facet): the nearest of the four exact edge
    projections is taken (``inside_zone`` False). ``beyond``: the edges the unconstrained projection
    (``xi_u``, ``eta_u``) lies beyond, bit ``e`` for edge ``e`` = 0..3 (eta=-1, xi=+1, eta=+1, xi=-1); 0 inside.
    """
    xi = 0.0
    eta = 0.0
    for it in range(8):
        p0, p1, p2, a0, a1, a2, c0, c1, c2 = _facet_point(x, segs, s, xi, eta)
        r0 = x[n, 0] - p0; r1 = x[n, 1] - p1; r2 = x[n, 2] - p2
        g11 = a0 * a0 + a1 * a1 + a2 * a2
        g22 = c0 * c0 + c1 * c1 + c2 * c2
        g12 = a0 * c0 + a1 * c1 + a2 * c2
        b1 = r0 * a0 + r1 * a1 + r2 * a2
        b2 = r0 * c0 + r1 * c1 + r2 * c2
        det = g11 * g22 - g12 * g12
        dxi = (g22 * b1 - g12 * b2) / det
        deta = (g11 * b2 - g12 * b1) / det
        xi += dxi
        eta += deta
        if abs(dxi) + abs(deta) < 1e-10:
            break
    inside = abs(xi) <= 1.0 and abs(eta) <= 1.0
    beyond = (1 if eta < -1.0 else 0) | (2 if xi > 1.0 else 0) | (4 if eta > 1.0 else 0) | (8 if xi < -1.0 else 0)
    xi_u = xi
    eta_u = eta
    if not inside:
        best = 1e300
        for e in range(4):
            t, d2 = _edge_closest(x, n, segs[s, e], segs[s, (e + 1) % 4])
            if d2 < best:
                best = d2
                # edge e runs from local node e to node e+1 (counter-clockwise in (xi, eta))
                if e == 0:
                    xi = -1.0 + 2.0 * t; eta = -1.0
                elif e == 1:
                    xi = 1.0; eta = -1.0 + 2.0 * t
                elif e == 2:
                    xi = 1.0 - 2.0 * t; eta = 1.0
                else:
                    xi = -1.0; eta = 1.0 - 2.0 * t
    p0, p1, p2, a0, a1, a2, c0, c1, c2 = _facet_point(x, segs, s, xi, eta)
    r0 = x[n, 0] - p0; r1 = x[n, 1] - p1; r2 = x[n, 2] - p2
    return xi, eta, math.sqrt(r0 * r0 + r1 * r1 + r2 * r2), inside, beyond, xi_u, eta_u


@njit(cache=True, fastmath=True, inline="always")
def _dual_gradient(a0, a1, a2, c0, c1, c2, wxi, weta, free_xi, free_eta):
    """Gradient with respect to the slave of ``wxi xi + weta eta`` (facet tangents ``a = dx/dxi``,
    ``c = dx/deta``): the free projection coordinates follow the slave through the dual basis of the
    tangents, a clamped one is fixed."""
    g11 = a0 * a0 + a1 * a1 + a2 * a2
    g22 = c0 * c0 + c1 * c1 + c2 * c2
    g12 = a0 * c0 + a1 * c1 + a2 * c2
    if free_xi and free_eta:
        det = g11 * g22 - g12 * g12
        ka = (wxi * g22 - weta * g12) / det
        kc = (weta * g11 - wxi * g12) / det
    elif free_xi:
        ka = wxi / g11
        kc = 0.0
    elif free_eta:
        ka = 0.0
        kc = weta / g22
    else:
        return 0.0, 0.0, 0.0
    return ka * a0 + kc * c0, ka * a1 + kc * c1, ka * a2 + kc * c2


#: zones of a node relative to one facet (:func:`_facet_gap`): its projection inside the facet, beyond open
#: surface edges only (the strip: the facet plane extended), or beyond a shared edge or corner (the border:
#: distance to the closest border point, or to the shared edge's line past the surface edge)
ZONE_INSIDE, ZONE_STRIP, ZONE_BORDER = 0, 1, 2


@njit(cache=True, fastmath=True)
def _facet_gap(x, segs, g_rad, seg_open, seg_sag, s, n):
    """Gap of node ``n`` to facet ``s`` alone, as the contact uses it.

    Returns (within reach, xi, eta, signed gap (negative = penetration), contact normal, tangential overshoot,
    overshoot gradient, zone, distance to the facet). Inside the facet (``ZONE_INSIDE``) the signed
    distance; beyond open surface edges only (``ZONE_STRIP``) the signed distance to the facet's bilinear
    surface extended past them while the overshoot (m; how far the projection lies past the open edges,
    measured along the facet's parametric directions) is below ``OPEN_TOL`` facet radii, "not within
    reach" farther out (see :func:`contact_forces_3d`); beyond a shared edge or corner (``ZONE_BORDER``)
    the distance to the closest border point signed by the side of the facet plane, or beyond a shared
    edge and an open edge the distance to the shared edge's line (up to the same reach past the surface
    edge). (xi, eta) is the point whose shape functions share the force among the facet's nodes: in the
    strip and on the line it lies outside [-1, 1]^2 (extended surface, extended edge). The facet's sag
    (``seg_sag``, :func:`facet_sags`) is taken off the gap, and the normal is the gradient of that gap with
    respect to the slave's position (unit without sag).
    """
    bxi, beta, bd, bin_, beyond, xi_u, eta_u = facet_closest(x, segs, s, n)
    p0, p1, p2, a0, a1, a2, c0, c1, c2 = _facet_point(x, segs, s, bxi, beta)
    n0 = a1 * c2 - a2 * c1; n1 = a2 * c0 - a0 * c2; n2 = a0 * c1 - a1 * c0
    nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    n0 /= nl; n1 /= nl; n2 /= nl
    r0 = x[n, 0] - p0; r1 = x[n, 1] - p1; r2 = x[n, 2] - p2
    rn = r0 * n0 + r1 * n1 + r2 * n2
    sgn = -1.0 if rn < 0.0 else 1.0
    tol = OPEN_TOL * g_rad[s]
    shared = beyond & ~seg_open[s]
    if not bin_ and shared != 0 and (beyond & seg_open[s]) != 0 and (shared & (shared - 1)) == 0:
        # beyond one shared edge and the open edge next to it: the line of the shared edge, extended past the
        # surface edge (where the strips of this facet and its neighbour across that edge end: each strip's
        # plane contains the line, so their gaps are the line's distance on the strip borders)
        e = 0
        while (shared >> e) & 1 == 0:
            e += 1
        if (seg_open[s] >> ((e + 3) % 4)) & 1 and (beyond >> ((e + 3) % 4)) & 1:
            kc, ko = e, (e + 1) % 4                     # the open edge before e meets it at e's first node
        else:
            kc, ko = (e + 1) % 4, e
        c = segs[s, kc]
        o = segs[s, ko]
        l0 = x[c, 0] - x[o, 0]; l1 = x[c, 1] - x[o, 1]; l2 = x[c, 2] - x[o, 2]
        ll = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
        l0 /= ll; l1 /= ll; l2 /= ll
        r0 = x[n, 0] - x[c, 0]; r1 = x[n, 1] - x[c, 1]; r2 = x[n, 2] - x[c, 2]
        ovl = r0 * l0 + r1 * l1 + r2 * l2             # along the line, past the corner
        if ovl >= tol:
            return False, bxi, beta, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ZONE_BORDER, bd
        p0 = r0 - ovl * l0; p1 = r1 - ovl * l1; p2 = r2 - ovl * l2
        dl = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
        # the foot on the line in the facet's parametric coordinates (extended along the edge past the
        # corner), so that the edge's two nodes take the force as the exact gradient of the line distance
        cxi = -1.0 if kc == 0 or kc == 3 else 1.0
        ceta = -1.0 if kc < 2 else 1.0
        oxi = -1.0 if ko == 0 or ko == 3 else 1.0
        oeta = -1.0 if ko < 2 else 1.0
        cxi += ovl / ll * (cxi - oxi)
        ceta += ovl / ll * (ceta - oeta)
        ov = max(ovl, 0.0)
        if ovl <= 0.0:
            l0 = 0.0; l1 = 0.0; l2 = 0.0
        if dl <= 1e-12 * ll:
            return True, cxi, ceta, 0.0, n0, n1, n2, ov, l0, l1, l2, ZONE_BORDER, bd
        return True, cxi, ceta, sgn * dl, sgn * p0 / dl, sgn * p1 / dl, sgn * p2 / dl, ov, l0, l1, l2, ZONE_BORDER, bd
    # the surface between the facet's corners bulges out of the bilinear facet by the sag
    # s = sa (1 - xi^2) + sb (1 - eta^2) (:func:`facet_sags`)
    sa = seg_sag[s, 0]
    sb = seg_sag[s, 1]
    sg = sa * (1.0 - bxi * bxi) + sb * (1.0 - beta * beta)
    q0, q1, q2 = _dual_gradient(a0, a1, a2, c0, c1, c2, -2.0 * sa * bxi, -2.0 * sb * beta,
                                abs(bxi) < 1.0, abs(beta) < 1.0)
    if not bin_ and shared == 0:
        # the strip beyond open edges: the facet's bilinear surface extended, with the orthogonal projection
        # (xi_u, eta_u) on it (continuous with the inside zone at the edge; the master nodes then take the
        # force with their extended shape functions there, the exact gradient of the gap); the sag stays at
        # its value on the edge. The overshoot past the open edges is measured along the parametric
        # directions (at a shared edge, the neighbour measures the same along that edge), with its gradient.
        p0, p1, p2, a0, a1, a2, c0, c1, c2 = _facet_point(x, segs, s, xi_u, eta_u)
        n0 = a1 * c2 - a2 * c1; n1 = a2 * c0 - a0 * c2; n2 = a0 * c1 - a1 * c0
        nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0 /= nl; n1 /= nl; n2 /= nl
        rn = (x[n, 0] - p0) * n0 + (x[n, 1] - p1) * n1 + (x[n, 2] - p2) * n2
        cx = min(max(xi_u, -1.0), 1.0)
        ce = min(max(eta_u, -1.0), 1.0)
        sg = sa * (1.0 - cx * cx) + sb * (1.0 - ce * ce)
        q0, q1, q2 = _dual_gradient(a0, a1, a2, c0, c1, c2, -2.0 * sa * cx, -2.0 * sb * ce,
                                    abs(xi_u) < 1.0, abs(eta_u) < 1.0)
        la = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        lc = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        oa = 0.0
        oc = 0.0
        if beyond & 2:
            oa = (xi_u - 1.0) * la
        elif beyond & 8:
            oa = (-1.0 - xi_u) * la
        if beyond & 4:
            oc = (eta_u - 1.0) * lc
        elif beyond & 1:
            oc = (-1.0 - eta_u) * lc
        ov = math.sqrt(oa * oa + oc * oc)
        if ov >= tol:
            return False, bxi, beta, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ZONE_STRIP, bd   # beyond the surface edge
        t0 = 0.0; t1 = 0.0; t2 = 0.0
        if ov > 1e-12 * tol:
            # d ov = (oa la sign_a d xi_u + oc lc sign_c d eta_u) / ov
            t0, t1, t2 = _dual_gradient(a0, a1, a2, c0, c1, c2, oa * la * (1.0 if beyond & 2 else -1.0) / ov,
                                        oc * lc * (1.0 if beyond & 4 else -1.0) / ov, True, True)
        return True, xi_u, eta_u, rn - sg, n0 - q0, n1 - q1, n2 - q2, ov, t0, t1, t2, ZONE_STRIP, bd
    if bin_ or bd <= 1e-9 * math.sqrt(nl):
        return (True, bxi, beta, sgn * bd - sg, n0 - q0, n1 - q1, n2 - q2, 0.0, 0.0, 0.0, 0.0,
                ZONE_INSIDE if bin_ else ZONE_BORDER, bd)
    # border zone (beyond a shared edge or corner): the distance to the closest point, signed by the side
    return (True, bxi, beta, sgn * bd - sg, sgn * r0 / bd - q0, sgn * r1 / bd - q1, sgn * r2 / bd - q2,
            0.0, 0.0, 0.0, 0.0, ZONE_BORDER, bd)


@njit(cache=True, fastmath=True)
def _signed_gap_3d(x, segs, g_rad, seg_open, seg_sag, cand, ncand, i, n, lbs, order, cutoff=1e300):
    """Master feature of slave ``i`` (node ``n``) among its candidates.

    Returns (facet or -1, xi, eta, signed gap (negative = penetration), contact normal, tangential overshoot,
    its gradient), see :func:`_facet_gap`. Among the facets that have the node inside or in their strip
    beyond open edges (where the gap is the distance to the facet's surface), the one whose gap is the
    smallest in magnitude: the gap is continuous where that choice passes from one facet to another (equal
    gaps there). Choosing by the distance instead breaks beyond an open surface edge, where the distance
    includes the tangential overshoot but the gap is the normal distance to the facet plane: at a crease of
    the master surface near its end face (a tip rounding meeting the flank), the overshoots of the two
    facets decide the choice and the gap jumps between the two planes' distances. Border zones (beyond a
    shared edge or corner) serve only where no facet has the node inside or in its strip (above a convex
    edge), the nearest by distance: there the sag taken off the gap lowers its magnitude below the
    distance, and the least magnitude would take a neighbour's border zone over the facet the node lies
    on, with a gap gradient pointing along the surface (a kink the time step crosses with an energy error,
    all of one sign for nodes sliding the same way). A facet with the node inside or in its strip is
    passed over for the nearest border zone when its gap exceeds that distance by more than the reach and
    sags (a facet elsewhere on the surface that happens to have the node in front of it). A node whose
    nearest facet (by distance) has it beyond the surface edge is not in contact (a farther facet would see
    it through its border zone, as deep as its distance to that facet's edge).

    A bilinear facet lies in the convex hull of its corners, so its distance from the node is at least
    (distance to the corners' centroid) - (largest corner distance from that centroid); a facet's gap is at
    least that bound less its reach beyond open edges and its sags. Candidates are taken in the order of the
    bound and the rest skipped once none can change the result; facet -1 is returned at once when every
    bound reaches ``cutoff`` (m). ``lbs`` (float) and ``order`` (int64), at least ``ncand[i]`` long, are
    scratch.
    """
    K = ncand[i]
    lbmin = 1e300
    slack = 0.0
    for m in range(K):
        s = cand[i, m]
        c0 = 0.0; c1 = 0.0; c2 = 0.0
        for q in range(4):
            nd = segs[s, q]
            c0 += x[nd, 0]; c1 += x[nd, 1]; c2 += x[nd, 2]
        c0 *= 0.25; c1 *= 0.25; c2 *= 0.25
        rad2 = 0.0
        for q in range(4):
            nd = segs[s, q]
            e0 = x[nd, 0] - c0; e1 = x[nd, 1] - c1; e2 = x[nd, 2] - c2
            rad2 = max(rad2, e0 * e0 + e1 * e1 + e2 * e2)
        d0 = x[n, 0] - c0; d1 = x[n, 1] - c1; d2 = x[n, 2] - c2
        lb = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - math.sqrt(rad2)
        slack = max(slack, OPEN_TOL * g_rad[s] + abs(seg_sag[s, 0]) + abs(seg_sag[s, 1]))
        # insertion into the sorted order (K is small)
        j = m
        while j > 0 and lbs[j - 1] > lb:
            lbs[j] = lbs[j - 1]; order[j] = order[j - 1]
            j -= 1
        lbs[j] = lb; order[j] = m
        lbmin = min(lbmin, lb)
    if K == 0 or lbmin >= cutoff:
        return -1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    near = -1
    near_d = 0.0
    near_in = False
    near_ok = False
    on = -1                          # best facet with the node inside or in its strip: least |gap|
    on_m = 0.0
    on_in = False
    bo = -1                          # best border zone: least distance
    bo_d = 0.0
    bo_m = 0.0
    on_r = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    bo_r = on_r
    for r in range(K):
        lb = lbs[r]
        if near >= 0 and lb > near_d * (1 + 1e-12):
            if not near_ok:
                break                # nothing nearer: out of contact whatever follows
            on_open = lb - slack <= (on_m if on >= 0 else (bo_d + slack if bo >= 0 else 1e300))
            bo_open = (bo < 0 or lb <= bo_d * (1 + 1e-12)) and (on < 0 or on_m > lb + slack)
            if not on_open and not bo_open:
                break                # no remaining facet can change the choice
        s = cand[i, order[r]]
        ok, xi, eta, g, g0, g1, g2, ov, t0, t1, t2, zone, d = _facet_gap(x, segs, g_rad, seg_open, seg_sag, s, n)
        inside = zone == ZONE_INSIDE
        if near < 0 or d < near_d * (1 - 1e-12) or (d <= near_d * (1 + 1e-12) and inside and not near_in):
            near = s; near_d = d; near_in = inside; near_ok = ok
        if not ok:
            continue
        m = abs(g)
        if zone != ZONE_BORDER:
            if on < 0 or m < on_m * (1 - 1e-12) or (m <= on_m * (1 + 1e-12) and inside and not on_in):
                on = s; on_m = m; on_in = inside; on_r = (xi, eta, g, g0, g1, g2, ov, t0, t1, t2)
        elif bo < 0 or d < bo_d * (1 - 1e-12) or (d <= bo_d * (1 + 1e-12) and m < bo_m):
            bo = s; bo_d = d; bo_m = m; bo_r = (xi, eta, g, g0, g1, g2, ov, t0, t1, t2)
    if not near_ok or (on < 0 and bo < 0):
        return -1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if on >= 0 and (bo < 0 or on_m <= bo_d + slack):
        best = on; r_ = on_r
    else:
        best = bo; r_ = bo_r
    return best, r_[0], r_[1], r_[2], r_[3], r_[4], r_[5], r_[6], r_[7], r_[8], r_[9]


@njit(cache=True)
def nearest_facets_3d(x, slaves, segs, g_rad, cand, ncand, seg_open, seg_sag):
    """Nearest master feature of every slave as the 3D contact sees it: facet (-1: none), (xi, eta) on it,
    signed gap [m] (negative = penetration), contact normal (from the master towards the slave: the gap's
    gradient, unit on a facet without sag),
    tangential overshoot beyond an open edge [m] (0 elsewhere) and its gradient with respect to the slave."""
    ns = slaves.shape[0]
    K = cand.shape[1]
    lbs = np.empty(K)
    order = np.empty(K, np.int64)
    facet = np.full(ns, -1, np.int64)
    xe = np.zeros((ns, 2))
    gap = np.zeros(ns)
    nrm = np.zeros((ns, 3))
    ov = np.zeros(ns)
    tdir = np.zeros((ns, 3))
    for i in range(ns):
        best, bxi, beta, bg, n0, n1, n2, o, t0, t1, t2 = _signed_gap_3d(x, segs, g_rad, seg_open, seg_sag, cand,
                                                                      ncand, i, slaves[i], lbs, order)
        facet[i] = best
        xe[i, 0] = bxi
        xe[i, 1] = beta
        gap[i] = bg
        nrm[i, 0] = n0
        nrm[i, 1] = n1
        nrm[i, 2] = n2
        ov[i] = o
        tdir[i, 0] = t0
        tdir[i, 1] = t1
        tdir[i, 2] = t2
    return facet, xe, gap, nrm, ov, tdir


@njit(cache=True)
def signed_gaps_3d(x, slaves, segs, g_rad, cand, ncand, seg_open, seg_sag):
    """Signed gap of every slave node (m; NaN without a master feature in reach), as the 3D contact sees it."""
    facet, _, gap, _, _, _ = nearest_facets_3d(x, slaves, segs, g_rad, cand, ncand, seg_open, seg_sag)
    return np.where(facet >= 0, gap, np.nan)


@njit(cache=True)
def open_edge_allowance(g_rad, seg_sag):
    """Reach (m) of the contact beyond the capture depth from a facet: ``OPEN_TOL`` times the largest facet
    radius (the tangential reach beyond an open surface edge, see :func:`contact_forces_3d`) plus the
    largest outward sag; a node farther than the capture depth plus this from every facet is not in
    contact."""
    g_rad_max = 0.0
    sag_max = 0.0
    for s in range(g_rad.shape[0]):
        g_rad_max = max(g_rad_max, g_rad[s])
        sag_max = max(sag_max, max(seg_sag[s, 0], 0.0) + max(seg_sag[s, 1], 0.0))
    return OPEN_TOL * g_rad_max + sag_max


#: facets whose normals differ by more than this angle (rad) meet at a crease (a tip chamfer on a flank), not on
#: one smooth surface (neighbouring 0.3 mm facets of an involute flank above the form circle differ by a few degrees)
CREASE_ANGLE = math.radians(12.0)


def facet_neighbours(segs: np.ndarray, g_pair: np.ndarray) -> np.ndarray:
    """Per 3D facet and border edge ``e`` (nodes ``e``, ``e + 1``, see :func:`facet_closest`): a facet of the same
    contact pair that shares that edge, -1 when none (an edge of the master surface). ``(nseg, 4)``."""
    segs = np.asarray(segs, np.int64)
    ed = np.stack([np.sort(np.stack([segs[:, e], segs[:, (e + 1) % 4]], axis=1), axis=1) for e in range(4)], axis=1)
    keys = np.concatenate([np.repeat(np.asarray(g_pair, np.int64), 4)[:, None], ed.reshape(-1, 2)], axis=1)
    _, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.ravel()
    owner = np.repeat(np.arange(len(segs)), 4)
    nbr = np.full(4 * len(segs), -1, np.int64)
    order = np.argsort(inv, kind="stable")
    same = np.nonzero(inv[order][1:] == inv[order][:-1])[0]
    nbr[order[same]] = owner[order[same + 1]]
    nbr[order[same + 1]] = owner[order[same]]
    return nbr.reshape(-1, 4)


def facet_sags(x: np.ndarray, segs: np.ndarray, g_pair: np.ndarray) -> np.ndarray:
    """Sag [m] of the smooth surface that bilinear facets discretize, per facet and parametric direction.

    The corners of a facet lie on the surface, which between them bulges out of the facet (convex) or in
    (concave). Across each edge, the curvature along the facet's parametric direction is estimated from
    the neighbouring facet of the same surface (same contact pair): ``kappa = (n_t - n_s) . d / |d|^2``
    with ``n`` the unit normals at the facet centres and ``d`` the vector between the centres (for a
    circle of radius rho: 1 / rho, positive when the surface turns away from its outward normal), the
    mean over the two sides (one at an open edge; none across a crease sharper than :data:`CREASE_ANGLE`).
    The surface then lies ``s(xi, eta) = sa (1 - xi^2) + sb (1 - eta^2)`` outside the facet, with the
    mid-chord sag ``sa = kappa_xi L_xi^2 / 8`` (``L_xi``: the facet's length between its xi = -1 and +1
    edges) and ``sb`` likewise along eta. Returns ``(nseg, 2)``: ``sa``, ``sb``; 2D segments give zeros.
    """
    segs = np.asarray(segs, np.int64)
    out = np.zeros((len(segs), 2))
    if segs.ndim != 2 or segs.shape[1] != 4 or len(segs) == 0:
        return out
    xs = np.asarray(x, float)[segs]                           # (nseg, 4, 3)
    cen = xs.mean(axis=1)
    a = 0.25 * (-xs[:, 0] + xs[:, 1] + xs[:, 2] - xs[:, 3])
    c = 0.25 * (-xs[:, 0] - xs[:, 1] + xs[:, 2] + xs[:, 3])
    nrm = np.cross(a, c)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    nbr = facet_neighbours(segs, g_pair)
    cos_crease = math.cos(CREASE_ANGLE)
    for col, (e_lo, e_hi, tang) in enumerate(((3, 1, a), (0, 2, c))):
        kap = np.zeros(len(segs))
        cnt = np.zeros(len(segs))
        for e in (e_lo, e_hi):
            t = nbr[:, e]
            ok = t >= 0
            s_ok = np.nonzero(ok)[0]
            t_ok = t[ok]
            ok2 = np.einsum("ij,ij->i", nrm[s_ok], nrm[t_ok]) > cos_crease
            s_ok, t_ok = s_ok[ok2], t_ok[ok2]
            d = cen[t_ok] - cen[s_ok]
            kap[s_ok] += np.einsum("ij,ij->i", nrm[t_ok] - nrm[s_ok], d) / np.einsum("ij,ij->i", d, d)
            cnt[s_ok] += 1
        has = cnt > 0
        length = 2.0 * np.linalg.norm(tang, axis=1)            # distance between the two edges' midpoints
        out[has, col] = kap[has] / cnt[has] * length[has] ** 2 / 8.0
    return out


@njit(cache=True, inline="always")
def edge_fade(ov, tol):
    """Penalty weight beyond an open edge and its derivative [1/m]: ``w = 1 - 3 t^2 + 2 t^3``, ``t = ov / tol``
    (1 at the edge, 0 at the reach ``tol``, both ends with zero slope)."""
    t = ov / tol
    return 1.0 - t * t * (3.0 - 2.0 * t), 6.0 * t * (t - 1.0) / tol


@njit(cache=True, inline="always")
def shape_q4(xi, eta):
    """Bilinear shape functions of a facet's four nodes at (xi, eta)."""
    return (0.25 * (1 - xi) * (1 - eta), 0.25 * (1 + xi) * (1 - eta),
            0.25 * (1 + xi) * (1 + eta), 0.25 * (1 - xi) * (1 + eta))


@njit(cache=True, fastmath=True)
def contact_slave_3d(x, v, slaves, s_pair, segs, g_k, g_rad, cand, ncand, p_mu, p_vreg, p_depth, seg_open,
                     seg_sag, allowance, i, lbs, order, out):
    """Contact of slave ``i`` alone (touches only row ``i`` of ``out`` and of the scratch ``lbs``,
    ``order`` (ns, K)): the slaves can be processed in parallel, :func:`contact_scatter_3d` then adds the
    forces. ``allowance``: :func:`open_edge_allowance`. ``out[i]``: facet (-1: no contact), xi, eta,
    force x, y, z on the slave [N], gap [m], penalty energy [J], friction power [W]."""
    out[i, 0] = -1.0
    if ncand[i] == 0:
        return
    n = slaves[i]
    p = s_pair[i]
    depth = p_depth[p]
    best, bxi, beta, bg, bn0, bn1, bn2, ov, t0, t1, t2 = _signed_gap_3d(x, segs, g_rad, seg_open, seg_sag, cand,
                                                                        ncand, i, n, lbs[i], order[i],
                                                                        depth + allowance)
    if best < 0 or bg >= 0.0 or -bg >= depth:
        return   # no facet, outside the master body, or deeper than the capture depth
    k = g_k[best]
    if ov > 0.0:
        # beyond an open edge: energy 0.5 k w(ov) g^2 fades to zero at the reach, force its gradient
        w, dw = edge_fade(ov, OPEN_TOL * g_rad[best])
        k *= w
        ft = -0.5 * g_k[best] * bg * bg * dw
    else:
        ft = 0.0
    fn = -k * bg
    fx = fn * bn0 + ft * t0; fy = fn * bn1 + ft * t1; fz = fn * bn2 + ft * t2
    mu = p_mu[p]
    pfric = 0.0
    if mu > 0.0:
        N = shape_q4(bxi, beta)
        vx = v[n, 0]; vy = v[n, 1]; vz = v[n, 2]
        for q in range(4):
            nd = segs[best, q]
            vx -= N[q] * v[nd, 0]; vy -= N[q] * v[nd, 1]; vz -= N[q] * v[nd, 2]
        nl = math.sqrt(bn0 * bn0 + bn1 * bn1 + bn2 * bn2)
        u0 = bn0 / nl; u1 = bn1 / nl; u2 = bn2 / nl
        vn = vx * u0 + vy * u1 + vz * u2
        vtx = vx - vn * u0; vty = vy - vn * u1; vtz = vz - vn * u2
        vt2 = vtx * vtx + vty * vty + vtz * vtz
        sc = mu * fn / math.sqrt(vt2 + p_vreg[p] * p_vreg[p])
        fx -= sc * vtx; fy -= sc * vty; fz -= sc * vtz
        pfric = sc * vt2
    out[i, 0] = best
    out[i, 1] = bxi
    out[i, 2] = beta
    out[i, 3] = fx
    out[i, 4] = fy
    out[i, 5] = fz
    out[i, 6] = bg
    out[i, 7] = 0.5 * k * bg * bg
    out[i, 8] = pfric


@njit(cache=True, fastmath=True)
def contact_scatter_3d(slaves, segs, out, f, gap):
    """Add the forces of :func:`contact_slave_3d` (rows of ``out``) to ``f``: the slave node gets the
    force, the facet's nodes minus the force times their shape functions at the projection. Fills
    ``gap``; returns (penalty energy, friction power)."""
    epot = 0.0
    pfric = 0.0
    for i in range(slaves.shape[0]):
        gap[i] = 0.0
        if out[i, 0] < 0.0:
            continue
        s = int(out[i, 0])
        bxi = out[i, 1]
        beta = out[i, 2]
        fx = out[i, 3]; fy = out[i, 4]; fz = out[i, 5]
        gap[i] = out[i, 6]
        epot += out[i, 7]
        pfric += out[i, 8]
        n = slaves[i]
        f[n, 0] += fx; f[n, 1] += fy; f[n, 2] += fz
        N = shape_q4(bxi, beta)
        for q in range(4):
            nd = segs[s, q]
            f[nd, 0] -= N[q] * fx; f[nd, 1] -= N[q] * fy; f[nd, 2] -= N[q] * fz
    return epot, pfric


@njit(cache=True)
def contact_forces_3d(x, v, slaves, s_pair, segs, g_k, g_rad, cand, ncand, p_mu, p_vreg, p_depth, f, gap, seg_open,
                      seg_sag):
    """Add 3D node-to-bilinear-facet penalty/friction forces to ``f``; see :func:`contact_forces_2d`.

    The closest feature of the master surface gives the signed distance, as in 2D. ``seg_open`` (nseg,)
    flags per facet, bit ``e`` set when border edge ``e`` (see :func:`facet_closest`) is an edge of the
    master surface (no neighbouring facet): beyond such an edge the closest feature is the edge itself,
    and the distance to it changes sign with the side of the facet plane only through zero when the
    node passes the edge exactly in that plane. A node just beyond it (tangential overshoot up to
    ``OPEN_TOL`` of the facet radius, measured along the facet's parametric directions, as its neighbour
    across a shared edge measures it along that edge) therefore takes the distance to the facet's bilinear
    surface extended past the edge (continuous with the inside zone; the facet's nodes take the force with
    their shape functions at the projection on the extension, which makes it the exact gradient of that
    distance), with its penalty energy faded to zero over that reach
    (:func:`edge_fade`; the force is the energy's gradient, so it has a tangential part pushing the node
    off the edge); farther out it is not in contact. A loaded node sliding off a cut flank end thus
    unloads continuously instead of dropping its energy ``k g^2 / 2`` at the reach. Without that rule a node
    sliding past the end of a cut master flank switched from no contact to a penetration as deep as its
    distance to the edge (tens of um) when it crossed the facet plane: 0.1-1 J out of nothing per event.

    Serial form of the two passes that the time loop runs with the slaves in parallel
    (:func:`contact_slave_3d`, then :func:`contact_scatter_3d`).
    """
    ns = slaves.shape[0]
    K = cand.shape[1]
    lbs = np.empty((ns, K))
    order = np.empty((ns, K), np.int64)
    out = np.empty((ns, 9))
    allowance = open_edge_allowance(g_rad, seg_sag)
    for i in range(ns):
        contact_slave_3d(x, v, slaves, s_pair, segs, g_k, g_rad, cand, ncand, p_mu, p_vreg, p_depth, seg_open,
                         seg_sag, allowance, i, lbs, order, out)
    return contact_scatter_3d(slaves, segs, out, f, gap)
