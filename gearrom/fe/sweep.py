"""Mesh-cycle sweep of the FE LTCA: static TE, mesh stiffness and load sharing over theta x torque.

Typical use::

    from gearrom.config import load_config
    from gearrom.fe.sweep import stiffness_sweep
    res = stiffness_sweep(load_config("thesis-spur").pair, torques=[60, 120, 240], n_positions=64)
    res.to_excitation().save("spur.nc")

The FE part (meshing, factorisation, influence coefficients) is cached on disk per gear
(:mod:`gearrom.fe.cache`), keyed by a hash of the gearrom version, the gear geometry, material and
mesh settings; torque and micro-geometry are not part of the key, so changing them re-runs only the
contact solves (milliseconds per position).
"""
from __future__ import annotations

import json
import logging
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.fe.cache import FECache, as_cache
from gearrom.fe.compliance import cached_compliance
from gearrom.fe.ltca import SpurLTCA
from gearrom.fe.mesh2d import MeshSettings

log = logging.getLogger(__name__)

DEFINITION = ("secant k = F_t / (STE - STE_kinematic) per position; F_t = torque / r_b2; transverse line of action; "
              "both gears: tooth bending + shear + fillet + rim/body down to a rigid bore + Hertzian contact "
              "(resolved flank mesh); tip edges rounded (config tip_edge_radius_mm, default 0.1 m_n), contact on the "
              "roundings off the line of action included; no shaft/bearing compliance")


def default_cache_dir() -> Path:
    """``$GEARROM_CACHE_DIR/fe`` (the CI sets it; ``~`` is expanded), else ``~/.cache/gearrom/fe``."""
    env = os.environ.get("GEARROM_CACHE_DIR")
    return (Path(env).expanduser() if env else Path.home() / ".cache" / "gearrom") / "fe"


@dataclass(frozen=True, eq=False)
class StiffnessResult:
    """Quasi-static FE results over one mesh period and several torques (SI units).

    Attributes
    ----------
    z1 : int
    theta : ndarray (n,)
        Input-gear angle in the mesh period [rad]; pair 0 enters contact at theta = 0.
    torque : ndarray (m,)
        Output torque [N m].
    ste : ndarray (m, n)
        Loaded static TE along the transverse line of action [m], positive = output lags.
    ste_kinematic : ndarray (n,)
        Unloaded TE from micro-geometry and errors alone [m].
    k_secant, k_tangent : ndarray (m, n)
        Mesh stiffness [N/m] (secant, see :data:`DEFINITION`; tangent dF/dSTE by a 0.1 % load step).
    pair_force : ndarray (m, n, p)
        Force per tooth pair [N] (its part of the line-of-action force torque / r_b2: the columns
        sum to it); pair index ``pairs``.
    pairs : ndarray (p,)
        Consecutive pair indices, every pair that carries load at some position and torque
        (-1: the next pair, in contact only prematurely; 0 enters at theta = 0...).
    max_pressure : ndarray (m, n)
        Largest contact pressure [Pa].
    pattern : ndarray (m, n, n_z, n_roll), optional
        Helical pairs: the contact pattern, largest contact pressure [Pa] per bin of face width x
        input-gear roll length (profile), per torque and position (:func:`gearrom.fe.ltca_helical.contact_pattern`).
    pattern_z, pattern_roll : ndarray, optional
        Bin edges of ``pattern``: axial position [m] (0 = mid-face) and input roll length [m].
    """

    z1: int
    theta: np.ndarray
    torque: np.ndarray
    ste: np.ndarray
    ste_kinematic: np.ndarray
    k_secant: np.ndarray
    k_tangent: np.ndarray
    pair_force: np.ndarray
    pairs: np.ndarray
    max_pressure: np.ndarray
    definition: str = DEFINITION
    metadata: dict = field(default_factory=dict)
    pattern: np.ndarray | None = None
    pattern_z: np.ndarray | None = None
    pattern_roll: np.ndarray | None = None

    @property
    def load_share(self) -> np.ndarray:
        """Pair force / total force (m, n, p)."""
        return self.pair_force / self.pair_force.sum(axis=2, keepdims=True)

    def to_excitation(self):
        """The hand-off table :class:`gearrom.excitation.table.MeshExcitation` (secant stiffness).

        Its ``load_share`` has one column per tooth pair that carries load somewhere in the table
        (``MeshExcitation.pairs``; e.g. -1, the next pair touching early, then 0, 1, ...), so the
        shares sum to 1 at every position.
        """
        from gearrom.excitation.table import MeshExcitation

        keep = _loaded_span(self.pair_force)
        meta = dict(self.metadata)
        meta.setdefault("source", "gearrom.fe LTCA (plane strain influence coefficients)")
        meta["theta_origin"] = "pair 0 enters contact at the input gear's start of active profile"
        return MeshExcitation(z1=self.z1, theta=self.theta, torque=self.torque, k=self.k_secant, e=self.ste,
                              load_share=self.load_share[..., keep], definition=self.definition,
                              max_pressure=self.max_pressure, metadata=meta, pairs=self.pairs[keep])

    def summary(self, j: int = -1) -> dict:
        """JSON-ready summary at torque index ``j`` (units in the keys)."""
        k = self.k_secant[j] * 1e-6
        e = self.ste[j] * 1e6
        return {
            "definition": self.definition,
            "torque_Nm": float(self.torque[j]),
            "mean_stiffness_N_per_um": float(k.mean()),
            "stiffness_ptp_N_per_um": float(np.ptp(k)),
            "mean_tangent_stiffness_N_per_um": float(self.k_tangent[j].mean() * 1e-6),
            "ste_mean_um": float(e.mean()),
            "ste_ptp_um": float(np.ptp(e)),
            "kinematic_te_ptp_um": float(np.ptp(self.ste_kinematic) * 1e6),
            "max_contact_pressure_MPa": float(self.max_pressure[j].max() * 1e-6),
            "mesh_angle_deg": np.degrees(self.theta).tolist(),
            "stiffness_N_per_um": k.tolist(),
            "ste_um": e.tolist(),
            "kinematic_te_um": (self.ste_kinematic * 1e6).tolist(),
            "load_share": self.load_share[j].tolist(),
            "load_share_pairs": self.pairs.tolist(),
            "max_contact_pressure_MPa_per_position": (self.max_pressure[j] * 1e-6).tolist(),
            **({"contact_pattern": self.pattern_summary(j)} if self.pattern is not None else {}),
        }

    def pattern_summary(self, j: int = -1) -> dict:
        """Contact pattern at torque index ``j`` over the mesh cycle (JSON-ready): the largest pressure
        per face-width x profile bin over all positions (what marking compound would show), and the
        loaded area share per position."""
        env = self.pattern[j].max(axis=0)
        zc = 0.5 * (self.pattern_z[1:] + self.pattern_z[:-1])
        rc = 0.5 * (self.pattern_roll[1:] + self.pattern_roll[:-1])
        return {"definition": "largest contact pressure per bin over the mesh cycle; rows: axial position z "
                              "(0 = mid-face), columns: input-gear roll length (profile, root to tip)",
                "z_mm": (zc * 1e3).tolist(), "roll_input_mm": (rc * 1e3).tolist(),
                "max_pressure_MPa": (env * 1e-6).tolist(),
                "loaded_bins_share_per_position": (self.pattern[j] > 0).mean(axis=(1, 2)).tolist()}

    # ---------------------------------------------------------------- I/O
    def save(self, path: str | Path) -> Path:
        """NPZ with the arrays plus JSON metadata (``definition``, ``metadata``)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {k: getattr(self, k) for k in ("theta", "torque", "ste", "ste_kinematic", "k_secant", "k_tangent",
                                               "pair_force", "pairs", "max_pressure")}
        if self.pattern is not None:
            arrays.update(pattern=self.pattern, pattern_z=self.pattern_z, pattern_roll=self.pattern_roll)
        np.savez(path, z1=self.z1, meta=json.dumps({"definition": self.definition, "metadata": self.metadata},
                                                   default=str), **arrays)
        return path

    @classmethod
    def load(cls, path: str | Path) -> "StiffnessResult":
        with np.load(path) as d:
            meta = json.loads(str(d["meta"]))
            opt = {k: d[k] for k in ("pattern", "pattern_z", "pattern_roll") if k in d.files}
            return cls(z1=int(d["z1"]), **{k: d[k] for k in ("theta", "torque", "ste", "ste_kinematic", "k_secant",
                                                              "k_tangent", "pair_force", "pairs", "max_pressure")},
                       definition=meta["definition"], metadata=meta["metadata"], **opt)

    def plot(self):
        """STE, stiffness, load share and pressure over the mesh period (all torques)."""
        from gearrom.plotting import subplots

        fig, ax = subplots(4, 1, figsize=(7, 10), sharex=True)
        deg = np.degrees(self.theta)
        for j, tq in enumerate(self.torque):
            lab = f"{tq:.4g} N m"
            ax[0].plot(deg, self.ste[j] * 1e6, label=lab)
            ax[1].plot(deg, self.k_secant[j] * 1e-6, label=lab)
            ax[3].plot(deg, self.max_pressure[j] * 1e-6, label=lab)
        ax[0].plot(deg, self.ste_kinematic * 1e6, "k--", label="unloaded")
        for n, p in enumerate(self.pairs):
            ax[2].plot(deg, self.load_share[-1, :, n], label=f"pair {p}")
        for a, lab in zip(ax, ("STE [um]", "k secant [N/um]", f"load share @ {self.torque[-1]:.4g} N m",
                               "max pressure [MPa]")):
            a.set_ylabel(lab)
            a.grid(alpha=0.3)
        ax[0].legend(fontsize=7)
        ax[2].legend(fontsize=7)
        ax[3].set_xlabel("input gear angle in mesh period [deg]")
        ax[0].set_title(self.metadata.get("config", "FE LTCA"), fontsize=9)
        fig.tight_layout()
        return fig

    def plot_pattern(self, j: int = -1):
        """Helical pairs: the contact pattern over the mesh cycle at torque index ``j`` (largest
        pressure per bin over all positions), face width x profile."""
        if self.pattern is None:
            from gearrom.errors import ModelError

            raise ModelError("no contact pattern in this result (spur pair, or a result saved without one)")
        from gearrom.plotting import subplots

        fig, ax = subplots(figsize=(7, 4))
        env = self.pattern[j].max(axis=0) * 1e-6
        im = ax.pcolormesh(self.pattern_z * 1e3, self.pattern_roll * 1e3, env.T, cmap="viridis", shading="flat")
        fig.colorbar(im, ax=ax, label="largest contact pressure over the cycle [MPa]")
        ax.set_xlabel("axial position z [mm] (0 = mid-face)")
        ax.set_ylabel("input roll length [mm] (root -> tip)")
        ax.set_title(f"{self.metadata.get('config', 'FE LTCA')}: contact pattern at {self.torque[j]:.4g} N m",
                     fontsize=9)
        fig.tight_layout()
        return fig


def _loaded_span(pair_force: np.ndarray) -> np.ndarray:
    """Boolean mask of the consecutive pair columns from the first to the last that carries load."""
    loaded = np.flatnonzero(pair_force.max(axis=(0, 1)) > 0)
    mask = np.zeros(pair_force.shape[2], bool)
    if loaded.size:
        mask[loaded[0]:loaded[-1] + 1] = True
    return mask


def build_ltca(pair, settings: MeshSettings | None = None, cache_dir: str | Path | FECache | None | bool = True,
               window: float = 0.4e-3, n_slices: int = 24, helical_model: str = "3d", settings3d=None) -> SpurLTCA:
    """Compliances of both gears (cached) and the LTCA object.

    ``cache_dir=True`` uses :func:`default_cache_dir`, ``None``/``False`` disables the cache. Both
    gears share one :class:`gearrom.fe.cache.FECache`: a damaged entry is reported, deleted and
    recomputed; an unwritable directory is reported once and the run continues without storing.
    Helical pairs: ``helical_model="3d"`` (default) gives :class:`gearrom.fe.ltca_helical.Helical3DLTCA`
    (3D FE compliances of each gear, mesh ``settings3d``: :class:`gearrom.fe.mesh3d.Mesh3DSettings`);
    ``"slices"`` the uncoupled transverse slices :class:`gearrom.fe.ltca_slices.HelicalSliceLTCA` (an
    approximation, with a warning).
    """
    if cache_dir is True:
        cache_dir = default_cache_dir()
    cache = as_cache(cache_dir)
    if pair.is_helical and helical_model not in ("3d", "slices"):
        from gearrom.errors import ModelError

        raise ModelError(f"helical_model must be '3d' or 'slices', got {helical_model!r}")
    if pair.is_helical and helical_model == "3d":
        from gearrom.fe.ltca_helical import build_helical3d

        return build_helical3d(pair, settings3d, cache, n_slices=n_slices)
    comps = tuple(cached_compliance(pair, i, settings, cache_dir=cache) for i in range(2))
    if pair.is_helical:
        import warnings

        from gearrom.fe.ltca_slices import HelicalSliceLTCA

        warnings.warn("helical pair: uncoupled transverse slices (plane-strain sections), not a 3D FE model; "
                      "end effects and lead-modification sensitivity are over-estimated", stacklevel=2)
        return HelicalSliceLTCA(pair, comps, window=window, n_slices=n_slices)
    return SpurLTCA(pair, comps, window=window)


def mesh_cycle(ltca: SpurLTCA, torques, n_positions: int = 64, mesh_index: int = 0, tangent: bool = True,
               metadata: dict | None = None, progress: bool = False) -> StiffnessResult:
    """Solve ``n_positions`` uniform positions of one mesh period at each output torque [N m]
    (``progress``: a progress bar over the positions)."""
    from gearrom.fe.ltca_helical import contact_pattern  # helical results only; imported once, not per position

    torques = np.sort(np.atleast_1d(np.asarray(torques, float)))
    n = int(n_positions)
    theta = np.arange(n) * ltca.period / n
    m, npair = torques.size, ltca.pair_range.size
    ste = np.zeros((m, n))
    ks, kt, pmax = np.zeros((m, n)), np.zeros((m, n)), np.zeros((m, n))
    pf = np.zeros((m, n, npair))
    kin = np.zeros(n)
    pattern = edges = None
    n_z = getattr(ltca, "n_slices", 24)  # pattern bins over the face: one per strip of the helical models
    t0 = time.perf_counter()
    eps = 1e-3
    positions = enumerate(theta)
    if progress:
        from tqdm import tqdm

        positions = tqdm(positions, total=n, desc="FE mesh cycle", unit="position", leave=False)
    for i, th in positions:
        tq = list(torques) + ([*(torques * (1 + eps))] if tangent else [])
        res = ltca.solve_many(th, tq, mesh_index)
        kin[i] = res[0].ste_kinematic
        for j in range(m):
            r = res[j]
            ste[j, i] = r.ste
            ks[j, i] = r.stiffness
            pmax[j, i] = r.max_pressure
            pf[j, i] = r.pair_force
            kt[j, i] = (eps * r.force / (res[m + j].ste - r.ste)) if tangent else np.nan
            if getattr(r, "z", None) is not None:  # helical: contact pattern over face width x profile
                ze, re_, pat = contact_pattern(r, ltca.pair, n_z=n_z)
                if pattern is None:
                    pattern, edges = np.zeros((m, n) + pat.shape), (ze, re_)
                pattern[j, i] = pat
    pairs = ltca.pair_range.copy()
    span = _loaded_span(pf)
    if span[0] or span[-1]:
        warnings.warn(f"tooth pair {pairs[0] if span[0] else pairs[-1]} at the end of the LTCA pair range carries "
                      "load: contact may extend to pairs outside the range", stacklevel=2)
    pf, pairs = pf[..., span], pairs[span]
    meta = {"n_positions": n, "solve_time_s": time.perf_counter() - t0, "mesh_index": mesh_index,
            "compliance_info": [c.info for c in ltca.c], "model": type(ltca).__name__}
    meta.update(metadata or {})
    definition = DEFINITION
    if ltca.pair.is_helical:
        definition = DEFINITION + "; helical: " + getattr(
            ltca, "model_description", f"{getattr(ltca, 'n_slices', 0)} uncoupled transverse slices")
    return StiffnessResult(z1=ltca.pair.z[0], theta=theta, torque=torques, ste=ste, ste_kinematic=kin, k_secant=ks,
                           k_tangent=kt, pair_force=pf, pairs=pairs, max_pressure=pmax,
                           definition=definition, metadata=meta, pattern=pattern,
                           pattern_z=None if edges is None else edges[0],
                           pattern_roll=None if edges is None else edges[1])


def stiffness_sweep(pair, torques, n_positions: int = 64, settings: MeshSettings | None = None,
                    cache_dir: str | Path | FECache | None | bool = True, **kw) -> StiffnessResult:
    """:func:`build_ltca` + :func:`mesh_cycle`."""
    return mesh_cycle(build_ltca(pair, settings, cache_dir), torques, n_positions, **kw)



def kinematic_te(ltca: SpurLTCA, n_cycles: int | None = None, n_per_cycle: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Unloaded TE from micro-geometry and errors (pitch, runout) over ``n_cycles`` mesh periods.

    No contact solve: the TE at each position is the smallest initial gap along the line of
    action (the first point that touches). Default: one input-gear revolution (z1 mesh periods).

    Returns
    -------
    angle : ndarray
        Input-gear rotation from the start [rad].
    te : ndarray
        Kinematic TE along the transverse line of action [m] (positive: output lags).
    """
    n_cycles = ltca.pair.z[0] if n_cycles is None else int(n_cycles)
    th = np.arange(n_per_cycle) * ltca.period / n_per_cycle
    angle, te = [], []
    for m in range(n_cycles):
        for t in th:
            c = ltca.candidates(t, mesh_index=m)
            angle.append(m * ltca.period + t)
            te.append(min(x[7] for x in c))
    return np.asarray(angle), np.asarray(te)
