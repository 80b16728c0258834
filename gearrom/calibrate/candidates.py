"""The candidates of a diagnosis: every target of every registered effect the settings allow."""
from __future__ import annotations

import gearrom.calibrate.effects  # noqa: F401  (registers the built-in effects)
from gearrom.calibrate.fit import Candidate, Context
from gearrom.calibrate.registry import PLUGINS

__all__ = ["make_candidates"]


def make_candidates(ctx: Context) -> list[Candidate]:
    """All candidates allowed by the settings and the simulator (:meth:`EffectPlugin.candidates`)."""
    out: list[Candidate] = []
    for name in ctx.s.candidates or tuple(PLUGINS):
        out.extend(PLUGINS[name].candidates(ctx))
    return out
