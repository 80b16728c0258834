"""Mesh excitation sources: what ``[rom] excitation`` can name, and the registry a new source joins.

A source is a function ``load(cfg, rom, torque, progress) -> MeshExcitation`` of the loaded config
(:class:`gearrom.config.GearConfig`), the validated ``[rom]`` section (dict), the run's output torque
[N m] and a progress flag, with an optional ``describe(ex) -> dict`` that adds provenance to the sweep's
summary. Built in:

* ``"fe"``: the quasi-static FE tables of the pair (:func:`gearrom.excitation.fe.fe_excitation`, the
  model of ``gearrom stiffness`` with the config's ``[fe]`` mesh) over the torque map
  ``rom.excitation_torques_Nm`` (default :data:`gearrom.excitation.fe.TORQUE_MAP` times the torque),
  computed on first use and cached by content;
* ``"analytical"``: the ISO 6336-1 shaped table (:func:`gearrom.excitation.analytical.analytical_excitation`).

Any other value is a MeshExcitation NetCDF file (relative to the config).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gearrom.errors import ConfigError
from gearrom.excitation.analytical import analytical_excitation
from gearrom.excitation.table import MeshExcitation

__all__ = ["SOURCES", "ExcitationSource", "describe_excitation", "fe_table_key", "load_excitation_source",
           "register_source"]


@dataclass(frozen=True)
class ExcitationSource:
    """A named mesh excitation source (see the module docstring for the call signatures)."""

    name: str
    load: Callable[..., MeshExcitation]
    describe: Callable[[MeshExcitation], dict] | None = None


#: registered sources by ``[rom] excitation`` value
SOURCES: dict[str, ExcitationSource] = {}


def register_source(source: ExcitationSource) -> ExcitationSource:
    """Make ``source.name`` a valid ``[rom] excitation`` value (replacing a source of that name)."""
    SOURCES[source.name] = source
    return source


def _fe_inputs(cfg, rom: dict, torque: float) -> tuple[list[float], int, Any]:
    """Torques [N m], positions per mesh period and 2D mesh settings of the ``"fe"`` table of ``cfg`` at ``torque``."""
    from gearrom.excitation.fe import torque_map
    from gearrom.fe.mesh2d import settings_from_section

    settings, extra = settings_from_section(cfg.section("fe"), str(cfg.source or cfg.name))
    torques = ([float(t) for t in rom["excitation_torques_Nm"]] or torque_map(torque)) + [float(torque)]
    return torques, int(extra.get("positions", 64)), settings


def _fe(cfg, rom: dict, torque: float, progress: bool = False) -> MeshExcitation:
    from gearrom.excitation.fe import fe_excitation

    torques, n_positions, settings = _fe_inputs(cfg, rom, torque)
    return fe_excitation(cfg.pair, torques, n_positions, settings, progress=progress,
                         config_name=cfg.name, config_digest=cfg.digest())


def fe_table_key(cfg, rom: dict, torque: float) -> str:
    """Cache key of the table the ``"fe"`` source gives for ``cfg`` (validated ``[rom]`` section ``rom``)
    at the output ``torque`` [N m], without computing it (:func:`gearrom.excitation.fe.excitation_key`);
    it covers the table's model revisions (:data:`gearrom.excitation.fe.TABLE_REVISION`) and the gearrom
    version."""
    from gearrom.excitation.fe import excitation_key

    torques, n_positions, settings = _fe_inputs(cfg, rom, torque)
    return excitation_key(cfg.pair, torques, n_positions, settings)


def _fe_describe(ex: MeshExcitation) -> dict:
    return {"cache_key": ex.metadata.get("cache_key", ""), "n_positions": int(ex.metadata.get("n_positions", ex.n_theta))}


def _analytical(cfg, rom: dict, torque: float, progress: bool = False) -> MeshExcitation:
    torques = sorted({float(t) for t in rom["excitation_torques_Nm"]} | {float(torque)})
    return analytical_excitation(cfg.pair, torques, n_theta=int(rom["n_theta"]), config_name=cfg.name,
                                 config_digest=cfg.digest())


register_source(ExcitationSource("fe", _fe, _fe_describe))
register_source(ExcitationSource("analytical", _analytical))


def load_excitation_source(cfg, rom: dict, torque: float, progress: bool = False) -> MeshExcitation:
    """The excitation ``rom["excitation"]`` names: a registered source or a MeshExcitation file.

    Raises
    ------
    ConfigError
        The file does not exist, or its table is for another number of input teeth.
    """
    src = rom["excitation"]
    if src in SOURCES:
        return SOURCES[src].load(cfg, rom, torque, progress=progress)
    path = Path(src)
    if not path.is_absolute() and cfg.source is not None:
        path = Path(cfg.source).parent / path
    if not path.exists():
        raise ConfigError(f"{cfg.source}: rom.excitation {str(src)!r} is neither a source "
                          f"({', '.join(sorted(SOURCES))}) nor an existing file ({str(path)!r})")
    ex = MeshExcitation.load(path)
    if ex.z1 != cfg.pair.z[0]:
        raise ConfigError(f"{cfg.source}: rom.excitation has z1 = {ex.z1}, the pair has {cfg.pair.z[0]}")
    return ex


def describe_excitation(src: str, ex: MeshExcitation) -> dict[str, Any]:
    """Provenance of an excitation for summaries: ``source`` (the name or the file), torques, grid, and
    what the source adds (the FE table's cache key and positions)."""
    info: dict[str, Any] = {"source": str(src), "torques_Nm": [float(t) for t in ex.torque], "n_theta": int(ex.n_theta)}
    if src in SOURCES and SOURCES[src].describe is not None:
        info.update(SOURCES[src].describe(ex))
    return info
