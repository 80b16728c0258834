"""Element reference geometry, row-sum lumped mass, stable time step and element colouring.

Everything here is computed once per model on the reference configuration (total Lagrangian):

* ``B`` (ne, nen, dim): Flanagan-Belytschko mean shape-function gradients (1/V) int dN/dX dV,
  which for Q4 equal the centroid gradients;
* ``V0`` (ne,): element volume (2D: area times thickness), m^3;
* ``gamma`` (ne, nen, nmodes): Flanagan-Belytschko hourglass shape vectors
  gamma_k = (h_k - (h_k . x_i) B_i) / nen, which are orthogonal to every linear field;
* for fully integrated elements (no hourglass modes, no hourglass control): the gradients ``Bg``
  (ne, ng, nen, dim) and weights ``Wg`` (ne, ng) at the 2^dim Gauss points;
* lumped nodal masses m_a = rho int N_a dV (row sum of the consistent mass);
* the stable time step from a nodal Gershgorin-type bound: since u^T K u <= sum_e lambda_e |u_e|^2
  with lambda_e the largest eigenvalue of the element stiffness (one-point part plus hourglass),
  omega_max^2 <= max_a (sum_{e containing a} lambda_e) / m_a (m_a the assembled lumped mass);
  for regular meshes this equals the element eigenvalue bound (Hughes 1987, sec. 9.3) and, unlike
  it, is not spoiled by the small row-sum masses of distorted elements. dt = safety 2 / omega_max.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from gearrom.errors import MeshError

_XI2 = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
_XI3 = np.array([[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0],
                 [-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]])


def _shape(xi_nodes: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Multilinear shape functions N (npt, nen) and derivatives dN (npt, nen, dim) at pts."""
    fac = 1.0 + pts[:, None, :] * xi_nodes[None, :, :]          # (npt, nen, dim)
    N = np.prod(fac, axis=2) / xi_nodes.shape[0]
    dN = np.empty(fac.shape)
    for j in range(xi_nodes.shape[1]):
        other = np.prod(np.delete(fac, j, axis=2), axis=2)
        dN[:, :, j] = xi_nodes[None, :, j] * other / xi_nodes.shape[0]
    return N, dN


def _gauss(nodes: np.ndarray, elements: np.ndarray):
    """Shape functions (ng, nen), Cartesian gradients (ne, ng, nen, dim) and det J (ne, ng) at the
    2^dim Gauss points (weights 1)."""
    dim = nodes.shape[1]
    xi_nodes = _XI2 if dim == 2 else _XI3
    g = 1.0 / np.sqrt(3.0)
    grid = np.array(np.meshgrid(*([[-g, g]] * dim), indexing="ij")).reshape(dim, -1).T
    N, dN = _shape(xi_nodes, grid)                                # (ng, nen), (ng, nen, dim)
    X = nodes[elements]                                           # (ne, nen, dim)
    J = np.einsum("eai,gaj->egij", X, dN)                         # dx_i/dxi_j
    detJ = np.linalg.det(J)                                       # (ne, ng)
    if np.any(detJ <= 0):
        bad = int(np.nonzero(np.any(detJ <= 0, axis=1))[0][0])
        raise MeshError(f"element {bad} is inverted or degenerate (det J <= 0 at a Gauss point); "
                        f"check the node order (Q4 counter-clockwise, Hex8 VTK order)")
    Jinv = np.linalg.inv(J)                                       # dxi_j/dx_i
    dNdX = np.einsum("gaj,egji->egai", dN, Jinv)
    return N, dNdX, detJ


def element_geometry(nodes: np.ndarray, elements: np.ndarray, thickness: float = 1.0):
    """Mean gradients, volumes, hourglass vectors and element row-sum masses per unit density.

    Returns
    -------
    B : ndarray (ne, nen, dim), 1/m
    V0 : ndarray (ne,), m^3 (2D: area * thickness)
    gamma : ndarray (ne, nen, nmodes), -
    me : ndarray (ne, nen), m^3 (int N_a dV; multiply by rho for the mass)
    """
    dim = nodes.shape[1]
    xi_nodes = _XI2 if dim == 2 else _XI3
    N, dNdX, detJ = _gauss(nodes, elements)
    X = nodes[elements]
    V = detJ.sum(axis=1)                                          # Gauss weights are 1
    B = np.einsum("egai,eg->eai", dNdX, detJ) / V[:, None, None]
    me = np.einsum("ga,eg->ea", N, detJ)
    if dim == 2:
        H = np.array([[1.0], [-1.0], [1.0], [-1.0]])
        V = V * thickness
        me = me * thickness
    else:
        s = xi_nodes
        H = np.stack([s[:, 1] * s[:, 2], s[:, 0] * s[:, 2], s[:, 0] * s[:, 1],
                      s[:, 0] * s[:, 1] * s[:, 2]], axis=1)
    nen = xi_nodes.shape[0]
    hx = np.einsum("ak,eai->eki", H, X)                           # (ne, nmodes, dim)
    gamma = (H[None, :, :] - np.einsum("eki,eai->eak", hx, B)) / nen
    return (np.ascontiguousarray(B), np.ascontiguousarray(V), np.ascontiguousarray(gamma),
            np.ascontiguousarray(me))


def full_integration_data(nodes: np.ndarray, elements: np.ndarray, thickness: float = 1.0):
    """Gauss-point gradients and weights of the fully integrated (2x2 / 2x2x2) element.

    Returns
    -------
    Bg : ndarray (ne, ng, nen, dim), 1/m
        dN_a/dX at each Gauss point.
    Wg : ndarray (ne, ng), m^3
        Gauss weight times det J (2D: times the thickness); ``Wg.sum(1)`` is the element volume.
    """
    _, dNdX, detJ = _gauss(nodes, elements)
    if nodes.shape[1] == 2:
        detJ = detJ * thickness
    return np.ascontiguousarray(dNdX), np.ascontiguousarray(detJ)


def _turn_xy(a: np.ndarray, c, s) -> np.ndarray:
    """``a`` (components on the last axis) with its x and y components turned about z by the angle whose cosine
    and sine are ``c`` and ``s`` (broadcast against ``a[..., 0]``); other components unchanged."""
    out = a.copy()
    out[..., 0] = c * a[..., 0] - s * a[..., 1]
    out[..., 1] = s * a[..., 0] + c * a[..., 1]
    return out


def congruent_shapes(nodes: np.ndarray, elements: np.ndarray, Bg: np.ndarray, Wg: np.ndarray,
                     rtol: float = 1e-9) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Group elements that are copies of each other by a rotation about the z axis and a translation.

    The teeth of a gear meshed with cyclic symmetry, and the layers of a helical gear extruded with a twist,
    repeat a few hundred element shapes many thousand times. An element that is such a copy of a shape has
    the shape's Gauss-point gradients rotated by its angle (b = R b_s) and the shape's weights, so the
    element pass can read one small table instead of streaming every element's own gradients.

    Each element is brought to a canonical frame: node 0 at the origin and the xy part of the vector
    ``sum_a a (x_a - x_0)`` along +x. Elements whose canonical coordinates agree (rounded to 1e-12 of the
    model's size) are candidates for one shape; every candidate is then checked against its own gradients
    and weights (relative difference below ``rtol``), and one that fails keeps a shape of its own.

    Returns
    -------
    table_Bg : ndarray (ns, ng, nen, dim), 1/m
        Gradients of each shape in its canonical frame.
    table_Wg : ndarray (ns, ng), m^3
        Weights of each shape.
    shape : ndarray (ne,) int64
        The shape of each element.
    rot : ndarray (ne, 2)
        cos and sin of the rotation about z from the canonical frame to the element.
    """
    X = nodes[elements]                                             # (ne, nen, dim)
    rel = X - X[:, :1, :]
    v = np.einsum("a,eai->ei", np.arange(X.shape[1], dtype=float), rel[:, :, :2])
    phi = np.arctan2(v[:, 1], v[:, 0])
    c, s = np.cos(phi), np.sin(phi)
    can = _turn_xy(rel, c[:, None], -s[:, None])
    q = 1e-12 * max(float(np.ptp(nodes, axis=0).max()), 1e-300)
    keys = np.round(can.reshape(len(can), -1) / q).astype(np.int64)
    _, rep, shape = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    shape = shape.ravel()
    # the shape's canonical gradients from its representative: b_s = R^T b_rep
    table = _turn_xy(Bg[rep], c[rep][:, None, None], -s[rep][:, None, None])
    tw = Wg[rep].copy()
    # every member against its own gradients and weights (in blocks: a few (ne, ng, nen, dim) temporaries)
    dev = np.empty(len(shape))
    for lo in range(0, len(shape), 65536):
        sl = slice(lo, lo + 65536)
        b = Bg[sl]
        d = np.abs(_turn_xy(table[shape[sl]], c[sl, None, None], s[sl, None, None]) - b).max(axis=(1, 2, 3))
        dev[sl] = np.maximum(d / np.abs(b).max(axis=(1, 2, 3)),
                             np.abs(tw[shape[sl]] - Wg[sl]).max(axis=1) / np.abs(Wg[sl]).max(axis=1))
    bad = np.flatnonzero(dev > rtol)
    if bad.size:
        shape[bad] = len(table) + np.arange(bad.size)
        table = np.concatenate([table, Bg[bad]])
        tw = np.concatenate([tw, Wg[bad]])
        c[bad], s[bad] = 1.0, 0.0
        used, shape = np.unique(shape, return_inverse=True)
        table, tw = table[used], tw[used]
    return np.ascontiguousarray(table), np.ascontiguousarray(tw), shape.astype(np.int64), np.stack([c, s], axis=1)


def _voigt_B(B: np.ndarray) -> np.ndarray:
    """Voigt strain-displacement matrices (ne, 3 or 6, nen*dim) of gradients ``B`` (ne, nen, dim)."""
    ne, nen, dim = B.shape
    if dim == 2:
        Bv = np.zeros((ne, 3, nen * dim))
        Bv[:, 0, 0::2] = B[:, :, 0]
        Bv[:, 1, 1::2] = B[:, :, 1]
        Bv[:, 2, 0::2] = B[:, :, 1]
        Bv[:, 2, 1::2] = B[:, :, 0]
    else:
        Bv = np.zeros((ne, 6, nen * dim))
        for i in range(3):
            Bv[:, i, i::3] = B[:, :, i]
        for r, (i, j) in enumerate(((1, 2), (0, 2), (0, 1))):
            Bv[:, 3 + r, i::3] = B[:, :, j]
            Bv[:, 3 + r, j::3] = B[:, :, i]
    return Bv


def _elasticity_sqrt(dim: int, lam: float, mu: float) -> np.ndarray:
    if dim == 2:
        D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])
    else:
        D = np.full((3, 3), lam) + 2 * mu * np.eye(3)
        D = np.block([[D, np.zeros((3, 3))], [np.zeros((3, 3)), mu * np.eye(3)]])
    w, Q = np.linalg.eigh(D)
    return Q @ np.diag(np.sqrt(w)) @ Q.T


def hourglass_coefficients(B: np.ndarray, V0: np.ndarray, lam: float, mu: float, rho: float,
                           kappa: float, visc: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-element hourglass stiffness (N/m) and viscosity (N s/m) (Flanagan-Belytschko form)."""
    dim = B.shape[2]
    bb = np.einsum("eai,eai->e", B, B) / dim
    khg = kappa * (lam + 2 * mu) * V0 * bb
    chg = visc * np.sqrt(rho * (lam + 2 * mu)) * V0 * np.sqrt(bb)
    return khg, chg


def element_max_eigenvalue(B, V0, gamma, lam, mu, khg) -> np.ndarray:
    """Largest eigenvalue of each element stiffness (one-point part + hourglass), N/m."""
    Dh = _elasticity_sqrt(B.shape[2], lam, mu)
    Bv = _voigt_B(B)
    G = np.einsum("ij,ejk,elk,lm->eim", Dh, Bv, Bv, Dh)
    lam_cs = np.linalg.eigvalsh(G)[:, -1] * V0
    lam_hg = khg * np.einsum("eak,eak->e", gamma, gamma)
    return lam_cs + lam_hg


def element_max_eigenvalue_full(Bg, Wg, lam, mu) -> np.ndarray:
    """Largest eigenvalue of each fully integrated (linearized) element stiffness, N/m."""
    ne, ng, nen, dim = Bg.shape
    Dh = _elasticity_sqrt(dim, lam, mu)
    K = np.zeros((ne, nen * dim, nen * dim))
    for g in range(ng):
        DB = np.einsum("ij,ejk->eik", Dh, _voigt_B(Bg[:, g]))
        K += Wg[:, g, None, None] * np.einsum("eik,eil->ekl", DB, DB)
    return np.linalg.eigvalsh(K)[:, -1]


def nodal_omega2(elements: np.ndarray, lam_e: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Upper bound of omega^2 seen by each node: sum of lambda_e over its elements / nodal mass."""
    s = np.zeros(mass.shape[0])
    np.add.at(s, elements, np.repeat(lam_e[:, None], elements.shape[1], axis=1))
    return s / mass


@njit(cache=True)
def color_elements(elements: np.ndarray, n_nodes: int) -> np.ndarray:
    """Greedy colouring: elements of one colour share no node (safe parallel scatter)."""
    ne, nen = elements.shape
    count = np.zeros(n_nodes + 1, np.int64)
    for e in range(ne):
        for a in range(nen):
            count[elements[e, a] + 1] += 1
    for i in range(n_nodes):
        count[i + 1] += count[i]
    adj = np.empty(count[n_nodes], np.int64)
    fill = count[:-1].copy()
    for e in range(ne):
        for a in range(nen):
            n = elements[e, a]
            adj[fill[n]] = e
            fill[n] += 1
    color = -np.ones(ne, np.int64)
    used = np.zeros(64, np.int64) - 1
    for e in range(ne):
        for a in range(nen):
            n = elements[e, a]
            for k in range(count[n], count[n + 1]):
                c = color[adj[k]]
                if c >= 0:
                    used[c] = e
        c = 0
        while used[c] == e:
            c += 1
        color[e] = c
    return color


def schedule_elements(elements: np.ndarray, n_nodes: int, n_parts: int, block: int = 256):
    """Order of the element pass of the compiled loop: blocks that may run in parallel, grouped in passes.

    The nodes are split into ``n_parts`` index ranges holding about equal element counts; an element whose
    nodes all lie in one range belongs to that part, the others (the interfaces) are coloured
    (:func:`color_elements`). Pass 0 holds one block per part (the parts share no node), each block in the
    order of its elements' lowest node, so that a thread walks its part of the mesh in node order and finds
    the nodes of consecutive elements in cache; each colour of the interface elements is a further pass, cut
    into blocks of ``block`` elements. On meshes numbered with locality (gmsh's, extruded layer by layer)
    this gathers and scatters far fewer cache lines than a pass per colour over the whole mesh.

    Returns
    -------
    order : ndarray (ne,)
        Element permutation; blocks are contiguous ranges of the permuted elements.
    bptr : ndarray (nblocks + 1,)
        Block ``b`` holds the permuted elements ``bptr[b]:bptr[b + 1]`` (run in sequence).
    cptr : ndarray (npasses + 1,)
        Pass ``c`` holds the blocks ``cptr[c]:cptr[c + 1]`` (no two share a node: run in parallel).
    """
    ne = elements.shape[0]
    lo = elements.min(axis=1)
    if ne == 0:
        return np.zeros(0, np.int64), np.zeros(1, np.int64), np.zeros(1, np.int64)
    n_parts = max(1, int(n_parts))
    splits = np.sort(lo)[(np.arange(1, n_parts) * ne) // n_parts]
    edges = np.concatenate([[0], splits, [n_nodes]])
    part_lo = np.searchsorted(edges, lo, side="right") - 1
    part_hi = np.searchsorted(edges, elements.max(axis=1), side="right") - 1
    inner = np.flatnonzero(part_lo == part_hi)
    inner = inner[np.lexsort((lo[inner], part_lo[inner]))]
    bounds = [0] + list(np.cumsum(np.bincount(part_lo[inner], minlength=n_parts)))
    order = [inner]
    cptr = [0, n_parts]
    rest = np.flatnonzero(part_lo != part_hi)
    ids, ends, per = colour_blocks(elements, rest, n_nodes, block, key=lo[rest])
    order.append(ids)
    bounds += [bounds[-1] + k for k in ends]
    cptr += list(cptr[-1] + np.cumsum(per))
    return (np.concatenate(order).astype(np.int64), np.asarray(bounds, np.int64), np.asarray(cptr, np.int64))


def colour_blocks(elements: np.ndarray, ids: np.ndarray, n_nodes: int, block: int = 256, key=None):
    """The elements ``ids`` in passes of one greedy colour each (:func:`color_elements`), each pass cut into
    blocks of ``block`` elements.

    ``key`` (one value per element of ``ids``): the order within a colour (stable; None: the order of ``ids``).
    Returns ``(order, ends, per_pass)``: ``ids`` permuted colour by colour, the end of each block counted from the
    first of them, and the number of blocks of each pass.
    """
    order, ends, per = [], [], []
    if ids.size == 0:
        return ids, ends, per
    color = color_elements(elements[ids], n_nodes)
    start = 0
    for c in range(color.max() + 1):
        sel = np.flatnonzero(color == c)
        if key is not None:
            sel = sel[np.argsort(key[sel], kind="stable")]
        order.append(ids[sel])
        cuts = list(range(block, sel.size, block)) + [sel.size]
        ends += [start + k for k in cuts]
        start += sel.size
        per.append(len(cuts))
    return np.concatenate(order), ends, per

