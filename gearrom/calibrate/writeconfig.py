"""The closed loop's output a user keeps: a config that extends the diagnosed one with the found effects.

:func:`diagnosed_config` turns the effects of a diagnosis (``gearrom.diagnosis/1`` summary) into
TOML keys of the gear and rig sections, so that ``gearrom sweep OUT.toml`` runs the model with them.
Each effect writes its own keys (:meth:`gearrom.calibrate.registry.EffectPlugin.write_config`, see the
effect modules of :mod:`gearrom.calibrate.effects`): runout, pitch deviations (signs of the ROM's
convention: positive = tooth ahead in its gear's rotation), flank modifications added to what the nominal
model used, the scaled rig parameter of a re-tuned mode.

A gear section that gets an effect is written whole (``enabled = true`` and every modification
key): values the nominal model did not use (a disabled drawing micro-geometry) become 0, so that
switching the section on adds only what the diagnosis found (a tip chamfer of the drawing is put at
the tip). Measurement-only effects (encoder
eccentricity) and changes with no config key are listed in the file's header, not applied.

Angles: the model's gear angle is the record's angle (each channel's first edge) plus the mesh phase
the diagnosis estimated for the first run; phases and tooth positions are converted with it.
Recordings that start at the encoder index share that zero; without an index the zero is fixed
only up to an offset, which changes the phase of the predicted shaft-order lines, not their
amplitudes.
"""
from __future__ import annotations

import math
from pathlib import Path


import gearrom.calibrate.effects  # noqa: F401  (registers the built-in effects)
from gearrom.calibrate.registry import GEARS, PLUGINS, ConfigDraft
from gearrom.errors import CalibrationError

MICRO_KEYS = ("tip_relief_um", "profile_crowning_um", "lead_crowning_um", "helix_slope_um", "profile_slope_um",
              "runout_um")


def _micro_base(raw: dict, gear: str, tip_diameter_m: float) -> dict:
    """The microgeometry table as the nominal model used it: where it was switched off, every
    modification 0 and the tip form diameter at the tip (no chamfer)."""
    sec = dict(raw.get(gear, {}).get("microgeometry", {}))
    if not sec.get("enabled", False):
        sec = {k: v for k, v in sec.items() if k not in ("pitch_deviations_um", "runout_phase_deg")}
        sec.update({k: 0.0 for k in MICRO_KEYS})
        if "tip_form_diameter_mm" in sec:
            sec["tip_form_diameter_mm"] = tip_diameter_m * 1e3
    sec["enabled"] = True
    return sec


def _index_phase_deg(summary: dict, z: tuple[int, int], psi0: float) -> float | None:
    """The mesh phase (deg of input angle) that puts the largest fitted displaced tooth on a whole tooth
    of the model, when the first run's GMF lines could not fix it; None otherwise.

    A displaced tooth is fitted on sub-pitch positions from the record's angle zero; the model places
    teeth on whole pitches from its gear angle zero. Where the GMF lines leave the mesh phase free, the
    tooth's position fixes it: the config then states it (``[calibrate] index_mesh_phase_deg``) for
    records that start at the same encoder index. ``psi0``: the first run's mesh phase, deg.
    """
    run0 = summary.get("runs", [{}])[0]
    if run0.get("mesh_phase_estimated", True):
        return None
    teeth = [e for e in summary.get("effects", []) if e["effect"] == "pitch_error"
             and "tooth_position_pitch" in e["parameters"]]
    if not teeth:
        return None
    e = max(teeth, key=lambda e: abs(e["parameters"]["deviation_um"]))
    # the model's gear angle is the record's plus psi; on either gear a shift of psi (input angle) moves
    # the tooth by psi z1 / 360 of that gear's pitches
    q = float(e["parameters"]["tooth_position_pitch"]) + psi0 * z[0] / 360.0
    return psi0 + (round(q) - q) * 360.0 / z[0]


def diagnosed_config(summary: dict, config) -> tuple[dict, list[str]]:
    """TOML content (units as written) of a config extending ``config`` with the diagnosed effects.

    Parameters
    ----------
    summary : dict
        ``DiagnosisResult.summary`` (``gearrom.diagnosis/1``).
    config : str or Path
        The config the diagnosis ran on (bundled name or TOML path).

    Returns
    -------
    doc : dict
        The TOML document (``extends`` the original).
    notes : list of str
        What was not written and why (header comments of the file).
    """
    from gearrom.config import as_config

    cfg = as_config(config)
    raw = cfg.raw
    ref = cfg.reference
    doc: dict = {"extends": ref, "name": f"{cfg.name}-diagnosed",
                 "description": f"{cfg.name} with the effects found by gearrom diagnose"}
    # the model's gear angles are the record's plus the mesh phase of the first run (see diagnose)
    z1, z2 = cfg.pair.z
    run0 = summary.get("runs", [{}])[0]
    psi_deg = (math.degrees(run0["mesh_phase_model_rad"]) if "mesh_phase_model_rad" in run0
               else float(run0.get("mesh_phase_deg") or 0.0))
    psi_index = _index_phase_deg(summary, cfg.pair.z, psi_deg)
    if psi_index is not None:
        psi_deg = psi_index
        doc["calibrate"] = {**raw.get("calibrate", {}), "index_mesh_phase_deg": psi_index}
    draft = ConfigDraft(doc=doc, raw=raw, pair=cfg.pair, micro={}, notes=[],
                        shift_deg={"input_gear": psi_deg, "output_gear": psi_deg * z1 / z2},
                        micro_base=lambda gear: _micro_base(raw, gear, cfg.pair.da[GEARS.index(gear)]))
    for e in summary.get("effects", []):
        name = e["effect"]
        if name not in PLUGINS:
            raise CalibrationError(f"write config: effect {name!r} is not in the library; it has no config mapping")
        PLUGINS[name].write_config(draft, e.get("target"), e["parameters"])
    micro, notes = draft.micro, draft.notes
    for gear, s in micro.items():
        doc.setdefault(gear, {})["microgeometry"] = s
    return doc, notes


def write_config(summary: dict, config, path: str | Path) -> Path:
    """Write :func:`diagnosed_config` as TOML to ``path`` (header comments list what was left out)."""
    import tomli_w

    doc, notes = diagnosed_config(summary, config)
    before, after = summary.get("error_before_rms_um"), summary.get("error_after_rms_um")
    head = ["# Written by gearrom diagnose: the diagnosed config with the effects it found.",
            f"# TE error rms on the diagnosed runs: {before:.4g} um before, {after:.4g} um after."
            if before is not None and after is not None else "#",
            "# Phases and tooth positions refer to the first run's encoder zero as gear angle zero."]
    head += [f"# not applied: {n}" for n in notes]
    out = Path(path)
    out.write_text("\n".join(head) + "\n" + tomli_w.dumps(doc))
    return out
