"""Flank influence coefficients of a helical gear from its 3D sector model, with an analytical near field.

The loaded (right) flank of each tooth is parametrised by ``(sigma, zeta)``: ``sigma = L^2 / (2 r_b)``
the involute arc length in the transverse section (``L`` the roll length) and ``zeta`` the axial
position (face width centred on 0). A coarse grid of ``n_sigma x n_zeta`` patches covers the
flank of tooth 0 from the root form circle to the end of the involute and over the face width.

Splitting of the compliance (Vijayakar's surface-integral idea): a 3D mesh cannot resolve the
Hertz zone (~0.1 mm), but its solution is accurate some distance from a load. Each patch ``a`` of
tooth 0 carries a unit normal force spread uniformly over it (P2-consistent point loads); the FE
response is read as the inward normal displacement at the point ``depth`` below the centre of
every grid patch ``b`` of the teeth ``offsets``: ``G[k][a, b]``. For the loaded tooth the
half-space (Boussinesq) displacement of the same patch load at the same depth point is
subtracted, ``B[0] = G[0] - H_depth``, which leaves the smooth "global" part (tooth bending,
shear, base rotation, rim); ``B[k] = G[k]`` for the other teeth. The LTCA adds back the
half-space *surface* compliance of its own fine contact patches
(:func:`gearrom.fe.halfspace.rect_surface`), so the near field is analytical and the FE part
does not depend on how the mesh resolves the contact.

The sector is the teeth ``-n..n`` (:mod:`gearrom.fe.mesh3d`); cyclic symmetry gives the coupling of
any two teeth, ``C(tooth m, a -> tooth q, b) = B[q - m][a, b]`` (zero beyond ``offsets``).
"""
from __future__ import annotations

import inspect
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
from gearrom.fe.elastic3d import ElasticBody3D
from gearrom.fe.halfspace import point_depth_kernel
from gearrom.fe.mesh3d import Mesh3DSettings, sector_mesh

log = logging.getLogger(__name__)

CODE_VERSION = "compliance-3d-v2"


def flank_geometry(pair, i: int, sigma, zeta, tooth: int = 0, h: float = 1e-7):
    """Points and outward unit normals of the right flank of ``tooth`` at ``(sigma, zeta)`` [m].

    Returns arrays (..., 3) in the gear's frame (:mod:`gearrom.fe.mesh3d`).
    """
    from gearrom.geometry.pair import inv
    from gearrom.geometry.profile import twist

    rb = pair.rb[i]
    z = pair.gears[i].z
    s0 = pair.s_t[i] / pair.d[i] + float(inv(pair.alpha_t))

    def point(sg, zt):
        r = np.sqrt(rb**2 + 2 * rb * sg)
        eta = s0 - inv(np.arccos(np.clip(rb / r, -1.0, 1.0)))
        phi = tooth * 2 * math.pi / z + np.asarray(twist(pair, i, zt))
        x, y = r * np.sin(eta), r * np.cos(eta)
        c, s = np.cos(phi), np.sin(phi)
        return np.stack([c * x - s * y, s * x + c * y, np.broadcast_to(zt, np.shape(x)) * 1.0], axis=-1), phi

    sg, zt = np.broadcast_arrays(np.asarray(sigma, float), np.asarray(zeta, float))
    X, phi = point(sg, zt)
    ds = point(sg + h, zt)[0] - point(sg - h, zt)[0]
    dz = point(sg, zt + h)[0] - point(sg, zt - h)[0]
    n = np.cross(ds, dz)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    perp = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=-1)  # +x of the tooth frame
    n *= np.sign(np.sum(n * perp, axis=-1))[..., None]
    return X, n


@dataclass(frozen=True, eq=False)
class FlankCompliance3D:
    """Coarse-grid influence coefficients of one helical gear (see module doc).

    Attributes
    ----------
    rb : float
        Base radius [m].
    sigma, zeta : ndarray
        Patch centres [m]; grid point ``a = i_sigma * n_zeta + i_zeta``.
    d_sigma, d_zeta : float
        Patch sizes [m].
    offsets : ndarray of int
        Tooth offsets of the blocks.
    G, B : ndarray (len(offsets), n, n)
        Raw FE response at depth and its smooth part (``B[0] = G[0] - H_depth``) [m/N].
    depth : ndarray (n,)
        Read-out depth below each grid point [m].
    youngs_modulus, poisson_ratio, face_width : float
    info : dict
    """

    rb: float
    sigma: np.ndarray
    zeta: np.ndarray
    d_sigma: float
    d_zeta: float
    offsets: np.ndarray
    G: np.ndarray
    B: np.ndarray
    depth: np.ndarray
    youngs_modulus: float
    poisson_ratio: float
    face_width: float
    info: dict

    @property
    def shape(self) -> tuple[int, int]:
        return self.sigma.size, self.zeta.size

    def block(self, offset: int, smooth: bool = True) -> np.ndarray:
        """Block for tooth offset ``offset`` (zeros beyond the computed teeth)."""
        k = np.flatnonzero(self.offsets == offset)
        A = self.B if smooth else self.G
        return A[k[0]] if k.size else np.zeros_like(A[0])

    @property
    def halfspace_factor(self) -> float:
        """(1 - nu^2) / (pi E) [1/Pa]."""
        return (1 - self.poisson_ratio**2) / (math.pi * self.youngs_modulus)

    def weights(self, sigma: np.ndarray, zeta: np.ndarray) -> np.ndarray:
        """Bilinear interpolation weights (q, n) of points on the grid (linear extrapolation clamped
        to half a patch beyond the outer centres)."""
        def axis(x, c):
            if c.size == 1:
                return np.zeros(x.size, int), np.zeros(x.size)
            u = np.clip((x - c[0]) / (c[1] - c[0]), -0.5, c.size - 0.5)
            k = np.clip(np.floor(u).astype(int), 0, c.size - 2)
            return k, u - k
        ks, ws = axis(np.asarray(sigma, float).ravel(), self.sigma)
        kz, wz = axis(np.asarray(zeta, float).ravel(), self.zeta)
        nz = self.zeta.size
        W = np.zeros((ks.size, self.sigma.size * nz))
        rows = np.arange(ks.size)
        for ds, fs in ((0, 1 - ws), (1, ws)):
            for dz, fz in ((0, 1 - wz), (1, wz)):
                np.add.at(W, (rows, (ks + ds) * nz + kz + dz), fs * fz)
        return W

    def save(self, path: str | Path) -> Path:
        """Write to NPZ (arrays, the info dict as JSON) with a content digest, atomically
        (:func:`gearrom.fe.cache.write_arrays`)."""
        return write_arrays(path, {**{k: getattr(self, k) for k in _ARRAY_FIELDS}, "info": json.dumps(self.info)})

    @classmethod
    def load(cls, path: str | Path) -> "FlankCompliance3D":
        """Read a file written by :meth:`save`; a damaged or incomplete file raises
        :class:`gearrom.fe.cache.CacheEntryError` (:func:`gearrom.fe.cache.read_arrays`)."""
        d = read_arrays(path)
        kw = {k: (float(d[k]) if d[k].ndim == 0 else d[k]) for k in _ARRAY_FIELDS}
        return cls(info=json.loads(str(d["info"])), **kw)


_ARRAY_FIELDS = ("rb", "sigma", "zeta", "d_sigma", "d_zeta", "offsets", "G", "B", "depth", "youngs_modulus",
                 "poisson_ratio", "face_width")
"""The fields of :class:`FlankCompliance3D` stored as arrays (the info dict is stored as JSON)."""


def flank_range(pair, i: int) -> tuple[float, float]:
    """Involute arc-length range [sigma_form, sigma_end] of gear ``i``'s flank [m]."""
    from gearrom.geometry.profile import tooth_profile

    rb = pair.rb[i]
    prof = tooth_profile(pair, i)
    L_lo = math.sqrt(max(prof.form_radius**2 - rb**2, 0.0))
    L_hi = float(np.nanmax(prof.roll))
    return L_lo**2 / (2 * rb), L_hi**2 / (2 * rb)


def compute_compliance3d(pair, i: int, settings: Mesh3DSettings | None = None, n_sigma: int = 8, n_zeta: int = 12,
                         depth: float = 0.6e-3, nq: int = 4, inset: float | None = None) -> FlankCompliance3D:
    """Mesh gear ``i``'s sector, factorise it once and compute its coarse influence coefficients.

    Parameters
    ----------
    n_sigma, n_zeta : int
        Patches over the flank height and the face width.
    depth : float
        Read-out depth [m] (limited to 0.3 x the local transverse tooth thickness near the tip).
    nq : int
        Quadrature points per patch direction for the loads and the half-space subtraction.
    inset : float, optional
        Load points are moved this far inside to lie in the faceted mesh [m] (default 5 % of the
        flank element size, above the chord error of the facets).
    """
    s = settings or Mesh3DSettings()
    inset = 0.05 * s.flank_size if inset is None else inset
    t0 = time.perf_counter()
    mesh = sector_mesh(pair, i, s)
    t1 = time.perf_counter()
    g = pair.gears[i]
    body = ElasticBody3D(mesh, g.material.youngs_modulus, g.material.poisson_ratio)
    t2 = time.perf_counter()
    s_lo, s_hi = flank_range(pair, i)
    b = g.face_width
    d_s, d_z = (s_hi - s_lo) / n_sigma, b / n_zeta
    sig = s_lo + (np.arange(n_sigma) + 0.5) * d_s
    zet = -0.5 * b + (np.arange(n_zeta) + 0.5) * d_z
    SG, ZT = np.meshgrid(sig, zet, indexing="ij")
    SG, ZT = SG.ravel(), ZT.ravel()
    n = SG.size
    r = np.sqrt(pair.rb[i] ** 2 + 2 * pair.rb[i] * SG)
    thick = np.array([pair.thickness_at(i, 2 * x) for x in r])
    dep = np.minimum(depth, 0.3 * thick)
    # patch quadrature (midpoint rule, equal weights)
    u = (np.arange(nq) + 0.5) / nq - 0.5
    qs = (SG[:, None, None] + d_s * u[None, :, None]).repeat(nq, 2).reshape(n, -1)
    qz = (ZT[:, None, None] + d_z * u[None, None, :]).repeat(nq, 1).reshape(n, -1)
    Xq, Nq = flank_geometry(pair, i, qs, qz, 0)
    P = body.probe_matrix((Xq - inset * Nq).reshape(-1, 3), -Nq.reshape(-1, 3), f"gear {i} flank load patches")
    col = np.repeat(np.arange(n), nq * nq)
    F = (P.T @ sp.csr_matrix((np.full(col.size, 1.0 / nq**2), (np.arange(col.size), col)), shape=(col.size, n)))
    offsets = np.arange(-s.teeth, s.teeth + 1)
    reads = []
    for j in offsets:
        Xb, Nb = flank_geometry(pair, i, SG, ZT, int(j))
        reads.append(body.probe_matrix(Xb - dep[:, None] * Nb, -Nb, f"gear {i} tooth {j} read-out points"))
    R = sp.vstack(reads).tocsr()
    U = body.solve(F)
    backend = body.backend
    body.release()  # the factor (GBs in MKL memory) is not needed any more
    G = (R @ U).reshape(offsets.size, n, n).transpose(0, 2, 1)  # G[k][a (load), b (response)]
    t3 = time.perf_counter()
    X0, N0 = flank_geometry(pair, i, SG, ZT, 0)
    H = point_depth_kernel(Xq.reshape(n, -1, 3), np.full((n, nq * nq), 1.0 / nq**2), X0 - dep[:, None] * N0, N0,
                           dep, g.material.youngs_modulus, g.material.poisson_ratio)  # (n load, n response)
    B = G.copy()
    k0 = int(np.flatnonzero(offsets == 0)[0])
    B[k0] -= H
    if np.any(np.diag(G[k0]) <= 0):
        raise MeshError(f"gear {i}: non-positive flank self-compliance in the 3D model (normals or mesh inverted)")
    info = {"nodes": int(mesh.points.shape[0]), "tets": int(mesh.tets.shape[0]), "dofs": int(body.ndof),
            "section_nodes": int(mesh.section.points.shape[0]), "layers": int(mesh.zeta.size - 1),
            "solver": backend, "time_mesh_s": t1 - t0, "time_factorise_s": t2 - t1,
            "time_influence_s": t3 - t2, "settings": asdict(s), "n_sigma": n_sigma, "n_zeta": n_zeta,
            "depth": depth, "gear": i}
    log.info("gear %d 3D compliance: %d dofs, %d patches, %.1f s", i, body.ndof, n, time.perf_counter() - t0)
    return FlankCompliance3D(rb=pair.rb[i], sigma=sig, zeta=zet, d_sigma=d_s, d_zeta=d_z, offsets=offsets, G=G, B=B,
                             depth=dep, youngs_modulus=g.material.youngs_modulus,
                             poisson_ratio=g.material.poisson_ratio, face_width=b, info=info)


def gear_key3d(pair, i: int, settings: Mesh3DSettings, **kw) -> str:
    """Hash of everything that affects one gear's 3D compliance (not torque, not micro-geometry).

    The key (:func:`gearrom.fe.cache.cache_key`) covers the gearrom version and
    :data:`CODE_VERSION`, the pair's basic rack data, the gear's definition (teeth, shift, hand,
    diameters, bore, tool, tip edge, material) and its derived diameters, the mesh settings and the
    options of :func:`compute_compliance3d` (``kw`` merged over its defaults).
    """
    g = pair.gears[i]
    gear = {k: v for k, v in asdict(g).items() if k not in ("micro", "name")}
    opts = {k: p.default for k, p in inspect.signature(compute_compliance3d).parameters.items()
            if p.default is not inspect.Parameter.empty and k != "settings"}
    opts.update(kw)
    data = {"mn": pair.mn, "alpha_n": pair.alpha_n, "beta": pair.beta, "gear": gear, "hand": g.hand, "z": g.z,
            "x": g.x, "da": pair.da[i], "df": pair.df[i], "dff": pair.dff[i],
            "tool": [pair.tool_addendum[i], pair.tool_tip_radius[i], g.tool.protuberance, g.tool.protuberance_angle],
            "b": g.face_width, "bore": g.bore_diameter, "tip_edge_radius": g.tip_edge_radius,
            "E": g.material.youngs_modulus, "nu": g.material.poisson_ratio, "mesh": asdict(settings), "options": opts}
    return cache_key(CODE_VERSION, data)


def cached_compliance3d(pair, i: int, settings: Mesh3DSettings | None = None,
                        cache_dir: str | Path | FECache | None = None, **kw) -> FlankCompliance3D:
    """:func:`compute_compliance3d` with a disk cache keyed by :func:`gear_key3d`.

    Parameters
    ----------
    cache_dir : str, Path, FECache or None
        Cache directory (``None``: no cache). A damaged entry is reported, deleted and recomputed;
        an unwritable directory is reported and the result returned without storing it
        (:class:`gearrom.fe.cache.FECache`).
    **kw
        Options of :func:`compute_compliance3d`.
    """
    s = settings or Mesh3DSettings()
    return cached(as_cache(cache_dir), f"flank3d-{gear_key3d(pair, i, s, **kw)}.npz", FlankCompliance3D.load,
                  lambda: compute_compliance3d(pair, i, s, **kw), FlankCompliance3D.save)
