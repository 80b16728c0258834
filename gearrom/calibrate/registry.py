"""The effect registry: what an effect of the diagnosis library is, and the table of registered effects.

An effect is one module (the built-in ones are in :mod:`gearrom.calibrate.effects`) that defines

* its :class:`EffectSpec`: name, targets, how it enters the model (``kind``), the drawing tolerance
  and the plausibility bound of its size, its physical signature and how to tell it from look-alikes;
* its candidate fit: a :class:`~gearrom.calibrate.fit.Candidate` subclass whose ``fit`` predicts the
  effect's contribution to every run and fits its size, and whose ``changes`` / ``measurement_term``
  give the model change the verification re-simulates (kinematic error tables, micro-geometry, rig
  scaling, or a measurement-only term);
* an :class:`EffectPlugin` with the effect's evidence text, the residual lines it explains, and how a
  fitted effect is written into a config;

and registers the plugin with :func:`register`. The diagnosis draws its candidates from :data:`PLUGINS`.

Conventions (all sizes are transmission-error equivalents along the transverse line of action, um,
positive = output lags; angles refer to the encoder zero of the record, i.e. each channel's first edge).
Plausibility bounds are at least five times the drawing tolerance: real parts are out of tolerance or
damaged, so a fit is not capped at the drawing; a fitted size above the tolerance is flagged.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from gearrom.errors import CalibrationError

__all__ = ["ENCODERS", "GEARS", "LIBRARY", "PLUGINS", "ConfigDraft", "EffectPlugin", "EffectSpec", "amp_phase",
           "check_name", "register", "suggestion", "unregister"]

GEARS = ("input_gear", "output_gear")
ENCODERS = ("input_encoder", "output_encoder")


@dataclass(frozen=True)
class EffectSpec:
    """What an effect is, for the fit and the report.

    Attributes
    ----------
    name : str
        Canonical name (the key of :data:`PLUGINS`).
    targets : tuple of str
        Allowed targets (``("",)`` for pair-level effects).
    kind : {"kinematic", "measurement", "micro", "rig"}
        How it enters: a kinematic error through the dynamics, a measurement-only error, a change of the
        mesh table, a rig parameter.
    tolerance : dict
        Drawing tolerance of the size parameter per target, um.
    bound : dict
        Plausibility bound used in the fit per target, um.
    signature : str
        The physical signature, for the report.
    size_key : str or None
        The parameter of the report that is the effect's size (compared with ``tolerance``).
    group : str
        Effects of one group are look-alikes that ``separation`` tells apart.
    separation : str
        The extra run or measurement that separates two candidates of the group.
    """

    name: str
    targets: tuple[str, ...]
    kind: str
    tolerance: dict
    bound: dict
    signature: str
    size_key: str | None = None
    group: str = ""
    separation: str = ""


@dataclass
class ConfigDraft:
    """The config a diagnosis writes, while effects add to it (see :func:`gearrom.calibrate.writeconfig.diagnosed_config`).

    Attributes
    ----------
    doc : dict
        The TOML document being written (``extends`` the original).
    raw : dict
        The original config's raw tables (read-only).
    pair : GearPair
    micro : dict
        ``[<gear>.microgeometry]`` tables being written, per gear (see :meth:`micro_section`).
    shift_deg : dict
        Model gear angle minus record angle per gear, deg (the first run's mesh phase).
    notes : list of str
        What was not written and why.
    micro_base : callable
        ``micro_base(gear) -> dict``: the original microgeometry table of a gear (keys with units).
    """

    doc: dict
    raw: dict
    pair: Any
    micro: dict
    shift_deg: dict
    notes: list
    micro_base: Any

    def micro_section(self, gear: str) -> dict:
        """The ``[<gear>.microgeometry]`` table of the written config (started from the original)."""
        if gear not in self.micro:
            self.micro[gear] = self.micro_base(gear)
        return self.micro[gear]


class EffectPlugin:
    """One effect of the library. Subclasses set :attr:`spec` and :attr:`candidate` and override the hooks.

    Attributes
    ----------
    spec : EffectSpec
    candidate : type
        The :class:`~gearrom.calibrate.fit.Candidate` subclass, called as ``candidate(name, target)``.
    not_evaluated : str
        Why the effect has no candidate when :meth:`candidates` returns none.
    """

    spec: EffectSpec
    candidate: type
    not_evaluated = "no candidate could be built"

    def candidates(self, ctx) -> list:
        """The candidates of this effect for a diagnosis context: one per target."""
        return [self.candidate(self.spec.name, t) for t in self.spec.targets]

    def evidence(self, ctx, trial, D: list) -> str:
        """Evidence for an accepted trial, appended to the explained share (``"; ..."`` or empty)."""
        return ""

    def report_extra(self, params: dict, info: dict) -> dict:
        """Parameters added to the report of an accepted effect (derived quantities)."""
        return {}

    def explains_line(self, target: str, label: str) -> bool:
        """Whether a residual line named ``label`` (``"GMF 2"``, ``"input order 1"``...) is one of this
        effect's lines, so that a leftover there is a misfit of the effect, not a new one."""
        return False

    def write_config(self, draft: ConfigDraft, target: str | None, params: dict) -> None:
        """Write the fitted effect into the config draft (or add a note why not)."""
        draft.notes.append(f"{self.spec.name}: no config mapping; not written")


#: registered effects by name
PLUGINS: dict[str, EffectPlugin] = {}
#: their specs by name (the library as the report and the CLI see it)
LIBRARY: dict[str, EffectSpec] = {}


def register(plugin: EffectPlugin) -> EffectPlugin:
    """Add an effect to the library (replacing one of the same name); returns the plugin."""
    spec = plugin.spec
    if not isinstance(spec, EffectSpec) or not spec.name:
        raise CalibrationError(f"effect plugin {plugin!r}: spec must be an EffectSpec with a name")
    if spec.kind not in ("kinematic", "measurement", "micro", "rig"):
        raise CalibrationError(f"effect {spec.name!r}: kind {spec.kind!r} is not kinematic, measurement, micro or rig")
    PLUGINS[spec.name] = plugin
    LIBRARY[spec.name] = spec
    return plugin


def unregister(name: str) -> None:
    """Remove an effect from the library (no error when it is not registered)."""
    PLUGINS.pop(name, None)
    LIBRARY.pop(name, None)


def check_name(name: str, target: str | None = None) -> EffectSpec:
    """The library entry ``name``, checking ``target``."""
    if name not in LIBRARY:
        raise CalibrationError(f"effect {name!r} is not in the library; choose from {sorted(LIBRARY)}")
    spec = LIBRARY[name]
    if target is not None and target not in spec.targets and not (target == "" and spec.targets == ("",)):
        raise CalibrationError(f"effect {name!r}: target {target!r} not allowed; choose from {spec.targets}")
    return spec


def effect_label(key: tuple[str, str]) -> str:
    """``effect/target`` of a (name, target) key; the effect's name alone where it has no target."""
    return f"{key[0]}/{key[1]}" if key[1] else key[0]


def suggestion(a: tuple[str, str], b: tuple[str, str]) -> str:
    """What extra run would separate candidates ``a`` and ``b`` ((name, target) each)."""
    sa, sb = LIBRARY.get(a[0]), LIBRARY.get(b[0])
    if sa is not None and sb is not None and sa.group and sa.group == sb.group and sa.separation:
        return sa.separation
    return "a run at a clearly different speed and one at a different load: the two effects predict different " \
           "speed and load dependence"


def amp_phase(x_cos: float, x_sin: float) -> tuple[float, float]:
    """Amplitude and phase (deg) of ``x_cos cos(theta) - x_sin sin(theta)``."""
    return math.hypot(x_cos, x_sin), math.degrees(math.atan2(x_sin, x_cos))
