"""Mesh excitation from the quasi-static FE (LTCA) over a mesh cycle and a torque map, cached by content.

:func:`fe_excitation` gives the :class:`~gearrom.excitation.table.MeshExcitation` of a pair from the
same model ``gearrom stiffness`` runs (spur: plane-strain influence coefficients; helical: the 3D FE
compliances), over ``n_positions`` mesh positions and a torque map around the operating torque
(:data:`TORQUE_MAP`, e.g. 0.25x-2x), so that a model can follow the load. The drawing
micro-geometry of the pair's gears enters the contact solves (no new FE solve).

The table is stored in ``<cache>/tables/table-<key>.nc`` (:class:`gearrom.fe.cache.FECache`: atomic
writes; a damaged entry is reported in one line and recomputed; an unwritable folder gives one
warning and the table is kept in memory). The key hashes the pair (geometry, tools, materials,
micro-geometry), the ``[fe]`` mesh settings, the torques, the position count, the model, the revision
of the compliances it is built on and the gearrom version. The FE compliances themselves come from the FE cache, so a new torque map or
micro-geometry costs only the contact solves.
"""
from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from pathlib import Path


from gearrom.excitation.table import MeshExcitation

log = logging.getLogger(__name__)

#: torque map of the tables, as multiples of the operating output torque
TORQUE_MAP = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0)
#: revision of the way the table is computed (part of the cache key)
TABLE_REVISION = "fe-table-v2"
#: revision of the helical slice model (transverse gaps; normal contact forces and the pressure on the
#: flank patch; sections shifted by the helix hand, :func:`gearrom.geometry.profile.contact_shift`), part of
#: the key of the tables of ``helical_model="slices"``
SLICES_REVISION = "slices-transverse-gaps-normal-forces-hand"


def torque_map(torque_out: float, factors: Sequence[float] = TORQUE_MAP) -> list[float]:
    """Output torques [N m] of the table: ``factors`` times ``torque_out`` (sorted, unique)."""
    return sorted({round(float(f) * float(torque_out), 9) for f in factors})


def _pair_key(pair) -> dict:
    def plain(obj):
        if dataclasses.is_dataclass(obj):
            return {f.name: plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
        if isinstance(obj, (list, tuple)):
            return [plain(v) for v in obj]
        if isinstance(obj, float):
            return repr(obj)
        return obj if isinstance(obj, (int, str, bool, type(None))) else repr(obj)

    return plain(pair)


def flank_pair(pair):
    """``pair`` without runout and pitch deviations: the table covers one mesh period of the flank
    geometry (tip relief, crowning, slopes); the ROM adds runout and pitch deviations as kinematic
    effects over the revolutions (:class:`gearrom.rom.mesh.Effects`), which a table of one mesh
    period cannot hold and which would otherwise count twice."""
    gears = []
    for g in pair.gears:
        m = g.micro
        if m.enabled and (m.pitch_deviations or m.runout):
            m = dataclasses.replace(m, pitch_deviations=(), runout=0.0, runout_phase=0.0)
        gears.append(dataclasses.replace(g, micro=m))
    return dataclasses.replace(pair, gears=tuple(gears))


def compliance_revision(pair, helical_model: str = "3d") -> str:
    """Code revision of the FE compliances an LTCA of ``pair`` is built on: the 3D sector compliances
    (:data:`gearrom.fe.compliance3d.CODE_VERSION`) for the ``"3d"`` model of a helical pair, the
    plane-strain ones (:data:`gearrom.fe.compliance.CODE_VERSION`) for a spur pair and the helical
    ``"slices"`` model. Part of the keys of the results computed from them (the compliances are cached
    under keys of their own, which a table's key does not otherwise cover)."""
    from gearrom.fe import compliance as c2d, compliance3d as c3d

    return c3d.CODE_VERSION if pair.is_helical and helical_model == "3d" else c2d.CODE_VERSION


def table_key(pair, torques: Sequence[float], n_positions: int, settings=None, helical_model: str = "3d",
              n_slices: int | None = None) -> str:
    """Content key of a table: pair, torques, positions, mesh settings, model, strips of a helical
    model (when not the default), the revision of the compliances behind it
    (:func:`compliance_revision`), the slice model's revision (:data:`SLICES_REVISION`, slice tables
    only), gearrom version."""
    from gearrom.fe.cache import cache_key
    from gearrom.fe.mesh3d import Mesh3DSettings

    model = helical_model if pair.is_helical else "2d"
    mesh = repr(Mesh3DSettings()) if model == "3d" else repr(settings)  # the mesh the LTCA is built on
    content = {"pair": _pair_key(pair), "torques_Nm": [repr(float(t)) for t in torques],
               "n_positions": int(n_positions), "mesh": mesh, "helical_model": model,
               "compliance": compliance_revision(pair, model)}
    if pair.is_helical and n_slices is not None and int(n_slices) != DEFAULT_SLICES:
        content["n_slices"] = int(n_slices)
    if model == "slices":
        content["slices_revision"] = SLICES_REVISION
    return cache_key(TABLE_REVISION, content)


#: strips over the face width of the helical LTCAs (:func:`gearrom.fe.sweep.build_ltca`'s default)
DEFAULT_SLICES = 24


def excitation_key(pair, torques: Sequence[float], n_positions: int = 64, settings=None, helical_model: str = "3d",
                   n_slices: int | None = None) -> str:
    """Cache key of the table :func:`fe_excitation` gives for these arguments (no table computed).

    Parameters
    ----------
    pair, torques, n_positions, settings, helical_model, n_slices
        As for :func:`fe_excitation` (the pair's runout and pitch deviations are dropped, :func:`flank_pair`;
        the torques [N m] are sorted and made unique).

    Returns
    -------
    str
        The :func:`table_key` of the table.
    """
    tq = sorted({float(t) for t in torques})
    return table_key(flank_pair(pair), tq, n_positions, settings, helical_model, n_slices)


#: tables already read or computed in this process, by key: (file stamp, table)
_LOADED: dict[tuple, tuple] = {}


def fe_excitation(pair, torques: Sequence[float], n_positions: int = 64, settings=None, *,
                  cache_dir: str | Path | bool | None = True, helical_model: str = "3d", progress: bool = False,
                  config_name: str = "", config_digest: str = "", n_slices: int | None = None) -> MeshExcitation:
    """Quasi-static FE mesh excitation of ``pair`` at the output ``torques`` [N m] (cached by content).

    Parameters
    ----------
    pair : GearPair
        The gear pair (its enabled flank micro-geometry is part of the contact solves; runout and
        pitch deviations are not, :func:`flank_pair`).
    torques : sequence of float
        Output torques of the table [N m] (see :func:`torque_map`).
    n_positions : int
        Mesh positions per mesh period.
    settings : MeshSettings, optional
        2D mesh settings (the config's ``[fe]`` section); helical pairs use the 3D model's mesh.
    cache_dir : path, bool or None
        FE cache folder (``True``: :func:`gearrom.fe.sweep.default_cache_dir`); the tables go to
        its ``tables`` subfolder. ``None``/``False``: no disk cache.
    helical_model : {"3d", "slices"}
        Helical pairs: the 3D FE model (default, as ``gearrom stiffness``) or uncoupled slices.
    progress : bool
        Show a progress bar over the mesh positions when the table is computed.
    config_name, config_digest : str
        Recorded in the table's metadata.
    n_slices : int, optional
        Helical pairs: strips over the face width on which the contact lines are sampled (default
        :data:`DEFAULT_SLICES`).

    Returns
    -------
    MeshExcitation
        Secant stiffness and static TE over (torque, theta), read once per process (later calls
        with the same key return the same object); ``metadata`` holds ``source``
        (``"fe"``), ``cache_key``, ``torques_Nm`` and ``n_positions``.
    """
    from gearrom.fe.cache import FECache, cached
    from gearrom.fe.sweep import build_ltca, default_cache_dir, mesh_cycle

    pair = flank_pair(pair)
    tq = sorted({float(t) for t in torques})
    if not tq or not all(t > 0 for t in tq):
        from gearrom.errors import ModelError

        raise ModelError(f"fe_excitation: torques must be positive N m, got {list(torques)}")
    key = excitation_key(pair, tq, n_positions, settings, helical_model, n_slices)
    folder = (default_cache_dir() if cache_dir is True else Path(cache_dir) if cache_dir else None)

    def compute() -> MeshExcitation:
        log.info("computing the FE excitation table (%d positions x %d torques) of %s", n_positions, len(tq),
                 config_name or "the pair")
        ltca = build_ltca(pair, settings, cache_dir if cache_dir is not None else None, helical_model=helical_model,
                          n_slices=DEFAULT_SLICES if n_slices is None else int(n_slices))
        meta = {"config": config_name, "config_digest": config_digest, "source": "fe", "cache_key": key,
                "torques_Nm": tq, "n_positions": int(n_positions)}
        return mesh_cycle(ltca, tq, n_positions, metadata=meta, progress=progress).to_excitation()

    file = folder / "tables" / f"table-{key}.nc" if folder is not None else None
    memo = (key, str(folder), config_name, config_digest)
    hit = _LOADED.get(memo)
    if hit is not None and hit[0] == _stamp(file):
        return hit[1]
    ex = cached(FECache(folder / "tables") if folder is not None else None, f"table-{key}.nc", MeshExcitation.load,
                compute, MeshExcitation.save, atomic=True)
    if len(_LOADED) >= 4:
        _LOADED.clear()
    _LOADED[memo] = (_stamp(file), ex)
    return ex


def _stamp(file: Path | None) -> tuple | None:
    """Size and modification time of a cached table file (None: no file): a table read earlier in
    this process is reused only while its file is unchanged, so a damaged or replaced file goes
    through the cache's checks again."""
    try:
        st = file.stat() if file is not None else None
    except OSError:
        return None
    return (st.st_size, st.st_mtime_ns) if st is not None else None
