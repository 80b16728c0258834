"""Flank influence coefficients of one gear from its plane-strain FE model (computed once per gear).

The loaded (right) flank of each tooth is sampled on a grid uniform in involute arc length
``sigma = L^2 / (2 r_b)`` (``L`` the roll length) with spacing ``spacing``; the grid continues with
the same spacing over the tip edge rounding (:mod:`gearrom.fe.tipedge`: ``sigma = u_t + rho phi``
there), so that contact can migrate from the involute onto the rounded tip edge. Grid point ``a`` of
tooth 0 carries a unit normal force spread uniformly over the patch ``[sigma_a - s/2, sigma_a + s/2]``
(a piecewise-constant pressure element); the response at grid point ``b`` of tooth ``j`` is the
inward normal displacement averaged over the same patch. The loads and read-outs use the same
operator, so ``G[0]`` is symmetric (Maxwell-Betti) and converges with the mesh like the
contact pressure it represents. Cyclic symmetry gives the coupling between any two teeth:
``C(tooth m, a -> tooth n, b) = G[n - m][a, b]``.

The bore is clamped (rigid reference node held fixed), so the compliances contain tooth
bending, shear, fillet and rim/body deformation down to the bore, and the local contact
(Hertz) deformation resolved by the fine flank mesh.
"""
from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from gearrom.errors import MeshError
from gearrom.fe.cache import FECache, as_cache, cache_key, cached, read_arrays, write_arrays
from gearrom.fe.elastic import ElasticBody2D, locate_on_chain
from gearrom.fe.mesh2d import MeshSettings, gear_mesh

log = logging.getLogger(__name__)

EDGE_GRID_FRACTION = 0.6
"""The flank grid covers this fraction of the tip edge rounding's angle (about 40 deg of ~65 deg):
contact further onto the rounding would need a relative flank rotation of that size."""

CODE_VERSION = "compliance-2d-v3"  # v3: grid over the tip edge rounding


@dataclass(frozen=True, eq=False)
class FlankCompliance:
    """Influence coefficients of the loaded flank of one gear.

    Attributes
    ----------
    rb : float
        Base radius [m].
    sigma : ndarray (n,)
        Grid in involute arc length from the base circle [m], uniform spacing ``spacing``.
    spacing : float
        Grid spacing = patch width [m].
    offsets : ndarray of int
        Tooth offsets ``j`` of the blocks in ``G``.
    G : ndarray (len(offsets), n, n)
        ``G[k][a, b]``: inward normal displacement at grid ``b`` of tooth ``offsets[k]`` per unit normal
        force [N] on patch ``a`` of tooth 0 [m/N] (total force over the face width).
    face_width : float
        Face width of the plane-strain model [m].
    info : dict
        Mesh size, dof count, timings, tip edge radius and its source.
    edge_radius : float
        Tip edge rounding radius [m] (0: sharp corner, the grid ends at the involute end).
    u_edge : float
        Flank coordinate where the involute ends and the rounding starts [m].
    """

    rb: float
    sigma: np.ndarray
    spacing: float
    offsets: np.ndarray
    G: np.ndarray
    face_width: float
    info: dict
    edge_radius: float = 0.0
    u_edge: float = math.inf

    @property
    def n_involute(self) -> int:
        """Number of grid points on the involute (the rest lie on the tip edge rounding)."""
        return int(np.searchsorted(self.sigma, self.u_edge, side="right"))

    def block(self, offset: int) -> np.ndarray:
        """The block ``G`` for tooth offset ``offset`` (zeros if it was not computed)."""
        k = np.flatnonzero(self.offsets == offset)
        return self.G[k[0]] if k.size else np.zeros_like(self.G[0])

    @property
    def roll(self) -> np.ndarray:
        """Roll length of the grid points [m]."""
        return np.sqrt(2 * self.rb * self.sigma)

    def save(self, path: str | Path) -> Path:
        """Write to NPZ (arrays, the info dict as JSON) with a content digest, atomically
        (:func:`gearrom.fe.cache.write_arrays`)."""
        return write_arrays(path, {"rb": self.rb, "sigma": self.sigma, "spacing": self.spacing,
                                   "offsets": self.offsets, "G": self.G, "face_width": self.face_width,
                                   "info": json.dumps(self.info), "edge_radius": self.edge_radius,
                                   "u_edge": self.u_edge})

    @classmethod
    def load(cls, path: str | Path) -> "FlankCompliance":
        """Read a file written by :meth:`save`; a damaged or incomplete file raises
        :class:`gearrom.fe.cache.CacheEntryError` (:func:`gearrom.fe.cache.read_arrays`)."""
        d = read_arrays(path)
        return cls(rb=float(d["rb"]), sigma=d["sigma"], spacing=float(d["spacing"]), offsets=d["offsets"],
                   G=d["G"], face_width=float(d["face_width"]), info=json.loads(str(d["info"])),
                   edge_radius=float(d["edge_radius"]), u_edge=float(d["u_edge"]))


def patch_operator(body: ElasticBody2D, edges: np.ndarray, node_coord: np.ndarray, to_coord, sigma: np.ndarray,
                   spacing: float, lo: float, hi: float, nq: int = 6, what: str = "patch"):
    """Sparse (ndof, n) operator of unit normal patch loads (equally: patch-averaged normal read-outs).

    Parameters
    ----------
    edges : ndarray (k, 2)
        Boundary edges of the loaded curve.
    node_coord : ndarray
        A coordinate of every mesh node that is monotonic along the curve (radius, angle...).
    to_coord : callable
        Maps arc length ``sigma`` [m] to that coordinate.
    sigma, spacing : ndarray, float
        Patch centres and width in arc length [m]; patches are clipped to ``[lo, hi]``.
    """
    a = np.clip(sigma - 0.5 * spacing, lo, hi)
    b = np.clip(sigma + 0.5 * spacing, lo, hi)
    frac = (np.arange(nq) + 0.5) / nq
    sq = a[:, None] + (b - a)[:, None] * frac[None, :]
    e, xi = locate_on_chain(body.mesh.points, edges, node_coord, to_coord(sq.ravel()), what=what)
    normals = body.outward_normals(edges[e])
    col = np.repeat(np.arange(sigma.size), nq)
    return body.edge_operator(edges[e], xi, -normals, np.full(col.size, 1.0 / nq), col, sigma.size)


def flank_grid(pair, i: int, spacing: float, form_radius: float, L_end: float | None = None,
               u_end: float | None = None) -> np.ndarray:
    """Grid of flank coordinates [m] from just above the form circle to the end of the involute
    (``L_end``, the roll length where a tip edge rounding starts; default the tip circle) or to the
    flank coordinate ``u_end`` (a point on the rounding)."""
    rb = pair.rb[i]
    L_lo = math.sqrt(max(form_radius**2 - rb**2, 0.0))
    L_hi = math.sqrt((0.5 * pair.da[i]) ** 2 - rb**2) if L_end is None else L_end
    s_lo, s_hi = L_lo**2 / (2 * rb), (L_hi**2 / (2 * rb) if u_end is None else u_end)
    n = int(math.floor((s_hi - s_lo) / spacing - 1e-9))
    if n < 4:
        raise MeshError(f"flank grid spacing {spacing * 1e3:.4f} mm leaves fewer than 4 points on the flank")
    # centre the grid so that the end patches lie inside the flank
    start = s_lo + 0.5 * (s_hi - s_lo - n * spacing) + 0.5 * spacing
    return start + spacing * np.arange(n)


def compute_compliance(pair, i: int, settings: MeshSettings | None = None, spacing: float | None = None,
                       offsets: int = 2, nq: int = 6) -> FlankCompliance:
    """Mesh gear ``i``, factorise it once and compute its flank influence coefficients.

    Parameters
    ----------
    pair : GearPair
    i : int
        Gear index.
    settings : MeshSettings
        Mesh density (default :class:`MeshSettings`).
    spacing : float, optional
        Grid spacing / patch width [m] (default: the flank element size).
    offsets : int
        Response teeth ``-offsets..offsets``.
    nq : int
        Quadrature points per patch.
    """
    from gearrom.fe.tipedge import FlankArc, tip_edge_radius
    from gearrom.geometry.profile import tooth_profile

    s = settings or MeshSettings()
    spacing = spacing or s.flank_size
    if offsets > s.near_teeth:
        raise MeshError(f"compliance offsets {offsets} exceed the named teeth near_teeth={s.near_teeth}")
    rho, rho_source = tip_edge_radius(pair, i)
    if rho_source == "default":
        log.warning("%s: no tip_edge_radius_mm in the config; the FE rounds the tip edges with %.3f mm "
                    "(0.1 m_n, drawing practice)", pair.gears[i].name, rho * 1e3)
    t0 = time.perf_counter()
    mesh = gear_mesh(pair, i, s, tip_edge_radius=rho)
    t1 = time.perf_counter()
    g = pair.gears[i]
    body = ElasticBody2D(mesh, g.material.youngs_modulus, g.material.poisson_ratio, g.face_width)
    t2 = time.perf_counter()
    rb = pair.rb[i]
    prof = tooth_profile(pair, i, tip_edge_radius=rho)
    arc = FlankArc.of(pair, i, rho)
    # the grid covers the involute and the first EDGE_GRID_FRACTION of the rounding's angle
    u_end = arc.u_t + rho * EDGE_GRID_FRACTION * arc.phi_full if rho > 0 else arc.u_t * (1 - 1e-9)
    sigma = flank_grid(pair, i, spacing, prof.form_radius * (1 + 1e-6), u_end=u_end)
    pts = mesh.points
    radius = np.hypot(pts[:, 0], pts[:, 1])

    ops = {}
    for j in range(-offsets, offsets + 1):
        parts = [mesh.curves.get(f"{n}_r_{j}") for n in ("involute", "edge")]
        edges = np.vstack([e for e in parts if e is not None and e.size]) if any(
            e is not None and e.size for e in parts) else None
        if edges is None or parts[0] is None or parts[0].size == 0:
            raise MeshError(f"gear {i}: the mesh has no loaded flank curve for tooth {j}")
        r = radius[np.unique(edges)]
        lo, hi = (float(v) for v in arc.u_of_radius(np.array([r.min(), r.max()])))
        ops[j] = patch_operator(body, edges, radius, arc.radius, sigma, spacing, lo, hi, nq,
                                f"gear {i} tooth {j} flank")
    P0 = ops[0]
    R = sp.hstack([ops[j] for j in range(-offsets, offsets + 1)]).tocsc()
    n = sigma.size
    G = np.empty((2 * offsets + 1, n, n))
    block = 16
    for a in range(0, n, block):
        U = body.solve(P0[:, a:a + block])
        resp = (R.T @ U).T  # (cols, (2 off + 1) n)
        G[:, a:a + block, :] = resp.reshape(resp.shape[0], 2 * offsets + 1, n).transpose(1, 0, 2)
    t3 = time.perf_counter()
    diag = np.diag(G[offsets])
    if np.any(diag <= 0):
        raise MeshError(f"gear {i}: non-positive flank self-compliance (normals or mesh inverted)")
    info = {"nodes": int(mesh.points.shape[0]), "triangles": int(mesh.triangles.shape[0]), "dofs": int(body.ndof),
            "time_mesh_s": t1 - t0, "time_factorise_s": t2 - t1, "time_influence_s": t3 - t2,
            "settings": asdict(s), "spacing": spacing, "gear": i, "tip_edge_radius_mm": rho * 1e3,
            "tip_edge_radius_source": rho_source, "edge_grid_points": int(np.sum(sigma > arc.u_t))}
    log.info("gear %d compliance: %d grid points, %.1f s", i, n, t3 - t0)
    return FlankCompliance(rb=rb, sigma=sigma, spacing=spacing, offsets=np.arange(-offsets, offsets + 1), G=G,
                           face_width=g.face_width, info=info, edge_radius=rho,
                           u_edge=arc.u_t if rho > 0 else math.inf)


def gear_key(pair, i: int, settings: MeshSettings, spacing: float, offsets: int) -> str:
    """Hash of everything that affects one gear's compliance (not torque, not micro-geometry).

    The key (:func:`gearrom.fe.cache.cache_key`) covers the gearrom version and
    :data:`CODE_VERSION`, the pair's basic rack data, the gear's definition (teeth, shift, diameters,
    bore, tool, tip edge, material) and its derived diameters, the mesh settings and the grid.
    """
    from gearrom.fe.tipedge import tip_edge_radius

    g = pair.gears[i]
    gear = {k: v for k, v in asdict(g).items() if k not in ("micro", "name")}
    data = {
        "mn": pair.mn, "alpha_n": pair.alpha_n, "beta": pair.beta, "gear": gear, "z": g.z, "x": g.x,
        "da": pair.da[i], "df": pair.df[i], "dff": pair.dff[i], "tool": [pair.tool_addendum[i], pair.tool_tip_radius[i],
        g.tool.protuberance, g.tool.protuberance_angle], "b": g.face_width, "bore": g.bore_diameter,
        "tip_edge_radius": tip_edge_radius(pair, i)[0], "edge_grid": EDGE_GRID_FRACTION,
        "E": g.material.youngs_modulus, "nu": g.material.poisson_ratio, "mesh": asdict(settings),
        "spacing": spacing, "offsets": offsets,
    }
    return cache_key(CODE_VERSION, data)


def cached_compliance(pair, i: int, settings: MeshSettings | None = None, spacing: float | None = None,
                      offsets: int = 2, cache_dir: str | Path | FECache | None = None) -> FlankCompliance:
    """:func:`compute_compliance` with a disk cache keyed by :func:`gear_key`.

    Parameters
    ----------
    cache_dir : str, Path, FECache or None
        Cache directory (``None``: no cache). A damaged entry is reported, deleted and recomputed;
        an unwritable directory is reported and the result returned without storing it
        (:class:`gearrom.fe.cache.FECache`).
    """
    s = settings or MeshSettings()
    spacing = spacing or s.flank_size
    return cached(as_cache(cache_dir), f"flank2d-{gear_key(pair, i, s, spacing, offsets)}.npz", FlankCompliance.load,
                  lambda: compute_compliance(pair, i, s, spacing, offsets), FlankCompliance.save)
