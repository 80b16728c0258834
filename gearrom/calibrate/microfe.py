"""Micro-geometry through the quasi-static FE tables, without a new FE solve, and its hand-off to a nominal table.

:class:`FEMicroModel` is the default :class:`~gearrom.calibrate.micromodel.MicroGeometryModel` of the
diagnosis. The flank compliances of both gears come from :func:`gearrom.fe.sweep.build_ltca` (FE
solved once per gear geometry and cached on disk by the FE package); a new micro-geometry only
changes the initial gaps, so each :class:`~gearrom.calibrate.micromodel.MicroMods` costs one contact
sweep over a mesh period (about 0.04 s spur, 0.4 s helical slices per torque) and no FE solve. Results
are cached in memory and on disk, keyed by a hash of the pair, the modifications, the torques and
the settings. Helical pairs go through whatever LTCA ``build_ltca`` returns for them (uncoupled
transverse slices today, the 3D model when it lands), so this module does not change with it. Spur
pairs use the plane model in ``SPUR_SLICES`` face slices (identical unless a lead modification, which
the plane model alone cannot see, varies the gap over the face width).

When the FE cache cannot be built (no gmsh, a geometry the mesher refuses), the analytical
:class:`~gearrom.calibrate.micromodel.SliceMicroModel` is used instead, with a warning.

:func:`with_micro` applies a micro-geometry to the *nominal* table of a simulator: the change of
STE and the relative change of stiffness between the modified and the nominal flanks, both from the
micro-geometry model, are added to / multiplied into the nominal table. The nominal model itself
(e.g. the ROM's analytical ISO table) stays what it was, so the diagnosis compares like with like.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import warnings
from pathlib import Path

import numpy as np

from gearrom.excitation.slices import MicroMods, SliceMicroModel
from gearrom.excitation.table import MeshExcitation

log = logging.getLogger(__name__)
#: part of the result cache key: the revision of the LTCA (gaps, forces, pressure, helix hand) behind the stored tables
CODE_VERSION = 7
SPUR_SLICES = 8  # face slices of a spur pair (uniform unless a lead modification is set)
_MEMORY: dict = {}
_LTCA: dict = {}


def _pair_key(pair) -> str:
    return hashlib.sha1(repr(pair).encode()).hexdigest()[:20]


def start_diameter(pair, i: int, d_ca: float | None) -> float:
    """Tip-relief start diameter of gear ``i``, m (None: 2/3 of the active profile from its start, the
    rule of :class:`~gearrom.calibrate.micromodel.SliceMicroModel`)."""
    if d_ca is not None:
        return float(d_ca)
    rho = pair.roll_start_active[i] + 2.0 / 3.0 * (pair.roll_tip[i] - pair.roll_start_active[i])
    return 2.0 * math.hypot(rho, pair.rb[i])


def pair_with(pair, mods: MicroMods):
    """``pair`` with its flank modifications replaced by ``mods`` (runout and pitch deviations removed:
    they are kinematic effects of the diagnosis; other flank fields kept where the config enables them)."""
    from gearrom.geometry.gear import MicroGeometry

    gears = []
    for i, g in enumerate(pair.gears):
        base = g.micro if g.micro.enabled else MicroGeometry()
        tr = float(mods.tip_relief[i])
        m = dataclasses.replace(
            base, enabled=True, tip_relief=tr,
            tip_relief_start_diameter=start_diameter(pair, i, mods.tip_relief_start_diameter[i]) if tr > 0 else None,
            lead_crowning=float(mods.lead_crowning) if i == 0 else 0.0,  # the pair's total, carried by gear 1
            helix_slope=float(mods.helix_slope) if i == 0 else 0.0,
            pitch_deviations=(), runout=0.0, runout_phase=0.0)
        gears.append(dataclasses.replace(g, micro=m))
    return dataclasses.replace(pair, gears=tuple(gears))


@dataclasses.dataclass(frozen=True)
class FEMicroModel:
    """Micro-geometry -> mesh excitation with the quasi-static FE LTCA (cached compliances, no FE solve).

    Parameters
    ----------
    n_positions : int
        Mesh positions per mesh period.
    cache_dir : str, Path, bool or None
        Directory of the result cache (``True``: ``<FE cache>/../calibrate``; ``None``/``False``: memory only).
    fallback : bool
        Use :class:`~gearrom.calibrate.micromodel.SliceMicroModel` with a warning when the FE LTCA cannot be built.
    helical_model : {"slices", "3d"}
        LTCA of helical pairs (``build_ltca(..., helical_model=...)``). Default: the plane-strain slices
        (a faster FE cache and modification). ``"3d"``: the 3D FE model, the better physics for lead
        modifications (costs in benchmarks/results/bench_stiffness_helical3d.json); the helical
        acceptance cases of the diagnosis are checked with the slices.
    """

    n_positions: int = 24
    cache_dir: str | Path | bool | None = True
    fallback: bool = True
    helical_model: str = "slices"

    @property
    def name(self) -> str:
        return f"gearrom.fe LTCA ({self.n_positions} positions per mesh period, no FE solve per modification)"

    def _dir(self) -> Path | None:
        if self.cache_dir is True:
            from gearrom.fe.sweep import default_cache_dir

            return default_cache_dir().parent / "calibrate"
        return Path(self.cache_dir) if self.cache_dir else None

    def ltca(self, pair):
        """The LTCA of ``pair``'s geometry (compliances from the FE cache), or None when it cannot be built."""
        key = (_pair_key(pair), self.helical_model)
        if key not in _LTCA:
            try:
                from gearrom.fe.sweep import build_ltca

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # the slice approximation is stated in the table definition
                    kw = {"helical_model": self.helical_model} if pair.is_helical else {}
                    lt = build_ltca(pair, **kw)  # the config's pair: shares the FE cache with `gearrom stiffness`
                    if not pair.is_helical:  # lead modifications vary over the face: slices of the plane model
                        from gearrom.fe.ltca_slices import HelicalSliceLTCA

                        lt = HelicalSliceLTCA(pair, lt.c, window=lt.window, tol=lt.tol, n_slices=SPUR_SLICES)
                    _LTCA[key] = lt
            except Exception as exc:  # noqa: BLE001  (any failure of the FE stack -> explicit fallback)
                if not self.fallback:
                    raise
                warnings.warn(f"the quasi-static FE tables could not be built ({type(exc).__name__}: {exc}); "
                              "micro-geometry effects use the analytical slice model instead", stacklevel=3)
                _LTCA[key] = None
        return _LTCA[key]

    def table_key(self, pair, torques_Nm, mods: MicroMods) -> str:
        """Key of the table :meth:`excitation` gives (cache file ``micro-<key>.nc``): the LTCA's revision
        (:data:`CODE_VERSION`), the gearrom version, the pair, ``mods``, the torques [N m], the positions, the
        helical model and the revision of the FE compliances behind it
        (:func:`gearrom.excitation.fe.compliance_revision`)."""
        from gearrom import __version__
        from gearrom.excitation.fe import compliance_revision

        tq = tuple(float(t) for t in np.atleast_1d(np.asarray(torques_Nm, float)))
        return hashlib.sha1(json.dumps([CODE_VERSION, __version__, _pair_key(pair), repr(mods), tq, self.n_positions,
                                        self.helical_model, compliance_revision(pair, self.helical_model)]
                                       ).encode()).hexdigest()[:24]

    def excitation(self, pair, torques_Nm, mods: MicroMods) -> MeshExcitation:
        """Mesh excitation table of ``pair`` with the flank modifications ``mods`` (FE contact, no FE solve)."""
        tq = tuple(float(t) for t in np.atleast_1d(np.asarray(torques_Nm, float)))
        ltca = self.ltca(pair)
        if ltca is None:
            return SliceMicroModel().excitation(pair, tq, mods)
        key = self.table_key(pair, tq, mods)
        if key in _MEMORY:
            return _MEMORY[key]
        from gearrom.fe.cache import FECache, cached

        def compute() -> MeshExcitation:
            from gearrom.fe.sweep import mesh_cycle

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                lt = _rebuild(ltca, pair_with(pair, mods))
                return mesh_cycle(lt, tq, n_positions=self.n_positions, tangent=False).to_excitation()

        d = self._dir()
        # a damaged entry is reported and recomputed; an unwritable folder: one warning, the table is kept
        ex = cached(FECache(d) if d else None, f"micro-{key}.nc", MeshExcitation.load, compute, MeshExcitation.save,
                    atomic=True)
        _MEMORY[key] = ex
        return ex

    def theta_shift(self, pair) -> float:
        """Input angle by which this model's table origin lags the analytical/slice convention, rad.

        The analytical tables (and :class:`~gearrom.calibrate.micromodel.SliceMicroModel`) put the entry of
        pair 0 at one face end at theta = 0; the FE LTCA of a helical pair puts it at the mid-face slice,
        i.e. the analytical angle is ``theta_FE + b tan(beta_b) / (2 r_b1)`` (taken from the LTCA's strip
        shifts, so the 3D model's convention is followed too). Zero for spur pairs.
        """
        lt = self.ltca(pair)
        if lt is None or not pair.is_helical:
            return 0.0
        sh = np.asarray(getattr(lt, "shift", [0.0]), float)  # input-angle shift of each face strip
        if sh.size < 2:
            return 0.5 * pair.face_width * math.tan(pair.beta_b) / pair.rb[0]
        return float(np.max(sh) + 0.5 * abs(sh[1] - sh[0]))  # the face end that enters first


def _rebuild(ltca, pair):
    """The same LTCA class with the same compliances for a pair with other flank modifications."""
    if hasattr(ltca, "with_pair"):
        return ltca.with_pair(pair)
    if hasattr(ltca, "n_slices"):
        return type(ltca)(pair, ltca.c, window=ltca.window, tol=ltca.tol, n_slices=ltca.n_slices)
    return type(ltca)(pair, ltca.c, window=ltca.window, tol=ltca.tol)


def micro_delta(model, pair, torque: float, nominal: MicroMods, mods: MicroMods, theta: np.ndarray):
    """STE change (m) and stiffness ratio of ``mods`` against ``nominal`` at input angles ``theta`` (rad,
    analytical-table origin), from ``model``."""
    a = model.excitation(pair, [torque], mods)
    b = model.excitation(pair, [torque], nominal)
    th = np.asarray(theta, float) - (model.theta_shift(pair) if hasattr(model, "theta_shift") else 0.0)
    de = a.ste(th, torque) - b.ste(th, torque)
    rk = a.stiffness(th, torque) / b.stiffness(th, torque)
    return de, rk


def with_micro(base: MeshExcitation, model, pair, torque: float, nominal: MicroMods, mods: MicroMods) -> MeshExcitation:
    """The nominal table ``base`` at ``torque`` with the change ``nominal -> mods`` of the micro-geometry model."""
    th = base.theta
    de, rk = micro_delta(model, pair, torque, nominal, mods, th)
    k = base.stiffness(th, torque) * rk
    e = base.ste(th, torque) + de
    ls = base.load_share_at(torque)
    meta = dict(base.metadata)
    meta["micro_change"] = {"model": getattr(model, "name", type(model).__name__), "nominal": repr(nominal),
                            "modified": repr(mods)}
    return MeshExcitation(z1=base.z1, theta=th, torque=np.array([float(torque)]), k=k[None, :], e=e[None, :],
                          load_share=ls[None], pairs=base.pairs, definition=base.definition + "; micro-geometry change added",
                          metadata=meta)
