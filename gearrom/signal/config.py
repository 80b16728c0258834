"""The ``[signal]`` section of a gear configuration: default TE processing settings.

Example (units in the key names; every key optional)::

    [signal]
    te_on = "line"            # or "pitch"
    lowpass_hz = 5000.0       # Bessel low-pass cut-off (-3 dB of one pass); absent = none
    lowpass_order = 4
    highpass_hz = 5.0         # Butterworth high-pass against drift; absent = none
    highpass_order = 2
    zero_phase = true
    detrend = "angle"         # "angle" (line in the input angle), "linear" (in time), "constant" or "none"
    window = "hann"           # window of the amplitude spectrum in Hz
    samples_per_rev = 4096    # angle grid for order spectra and averages
    edge_interp = "cubic"     # or "linear"
    grid_fs_hz = 100000.0     # common time grid (default from the edge rate)
    rpm_tolerance = 0.05
    ratio_tolerance = 0.005
    strict = false
    # edge checks (kind "edges" and "quadrature")
    double_ratio = 0.5        # interval / reference below which an edge is spurious
    gap_ratio = 1.5           # interval / reference above which edges were dropped
    integer_tol = 0.3         # largest distance from a whole number of dropped edges
    max_fill_edges = 64
    max_repairs = 1000
    timing_resolution_s = 2e-5  # default: 1/clock_hz, or the sample step of a sampled record
    edge_period = 4           # compare intervals 4 edges apart (x4); default: the decoding factor
    # time window and trimming
    t_start_s = 0.5
    t_end_s = 3.0
    trim = true               # cut standstill/reversals of sampled records (reported)
    min_speed_fraction = 0.05 # standstill: slower than this fraction of the highest speed
    estimate_scale = "none"   # "input" / "output": estimate that encoder's counts per shaft rev

``gearrom te`` and ``gearrom diagnose`` start from these and lets its options override them.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gearrom.errors import ConfigError
from gearrom.signal.edges import ReadSettings
from gearrom.signal.filters import FilterSettings
from gearrom.signal.te import TESettings

# key -> (type, target, field): target "te", "filter" or "read"
SIGNAL_KEYS: dict[str, tuple[type | tuple[type, ...], str, str]] = {
    "te_on": (str, "te", "te_on"),
    "lowpass_hz": ((int, float), "filter", "lowpass_hz"),
    "lowpass_order": (int, "filter", "lowpass_order"),
    "highpass_hz": ((int, float), "filter", "highpass_hz"),
    "highpass_order": (int, "filter", "highpass_order"),
    "zero_phase": (bool, "filter", "zero_phase"),
    "detrend": (str, "filter", "detrend"),
    "window": (str, "te", "window"),
    "samples_per_rev": (int, "te", "samples_per_rev"),
    "ratio_tolerance": ((int, float), "te", "ratio_tolerance"),
    "edge_interp": (str, "read", "edge_interp"),
    "grid_fs_hz": ((int, float), "read", "fs_hz"),
    "rpm_tolerance": ((int, float), "read", "rpm_tolerance"),
    "strict": (bool, "read", "strict"),
    "double_ratio": ((int, float), "read", "double_ratio"),
    "gap_ratio": ((int, float), "read", "gap_ratio"),
    "integer_tol": ((int, float), "read", "integer_tol"),
    "max_fill_edges": (int, "read", "max_fill_edges"),
    "max_repairs": (int, "read", "max_repairs"),
    "timing_resolution_s": ((int, float), "read", "timing_resolution_s"),
    "edge_period": (int, "read", "edge_period"),
    "t_start_s": ((int, float), "read", "t_start_s"),
    "t_end_s": ((int, float), "read", "t_end_s"),
    "trim": (bool, "read", "trim"),
    "min_speed_fraction": ((int, float), "read", "min_speed_fraction"),
    "estimate_scale": (str, "te", "estimate_scale"),
}


def _build(values: Mapping[str, Any], blame: Mapping[str, str]) -> tuple[TESettings, ReadSettings]:
    """Settings from ``values``; ``blame[key]`` names where each value came from, for the messages."""
    kw: dict[str, dict[str, Any]] = {"te": {}, "filter": {}, "read": {}}
    for key, val in values.items():
        if key not in SIGNAL_KEYS:
            raise ConfigError(f"{blame[key]}: unknown key {key!r} in [signal]; allowed: {sorted(SIGNAL_KEYS)}")
        typ, target, name = SIGNAL_KEYS[key]
        if isinstance(val, bool) and typ is not bool or not isinstance(val, typ):
            raise ConfigError(f"{blame[key]}: [signal] key {key!r} has the wrong type ({val!r})")
        kw[target][name] = float(val) if typ == (int, float) else val
    te = TESettings(filters=FilterSettings(**kw["filter"]), **kw["te"])
    return te, ReadSettings(**kw["read"])


def settings_from_section(section: Mapping[str, Any], where: str = "[signal]",
                          overrides: Mapping[str, Any] | None = None,
                          option_names: Mapping[str, str] | None = None) -> tuple[TESettings, ReadSettings]:
    """TE and reader settings from a ``[signal]`` section, with optional overrides (same keys).

    Parameters
    ----------
    section : mapping
        The section (``GearConfig.section("signal")``).
    where : str
        Name of the config for messages.
    overrides : mapping, optional
        Values that replace the section's (e.g. from command-line options); None values are ignored.
    option_names : mapping, optional
        ``key -> option`` (e.g. ``{"grid_fs_hz": "--fs-hz"}``): an error caused by an override names
        the option instead of the config's ``[signal]`` section.

    Raises
    ------
    ConfigError
        Unknown key, wrong type or invalid value: names the key of the section, or the override
        (option) that makes the settings invalid.
    """
    values = dict(section)
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    names = dict(option_names or {})

    def label(key: str) -> str:
        return f"option {names[key]}" if key in names else f"override {key!r}"

    try:
        _build(values, {k: where for k in values})
    except ConfigError as exc:
        msg = str(exc)
        raise ConfigError(msg if msg.startswith(where) else f"{where}: [signal]: {msg}") from None
    for key, val in given.items():  # each override alone on top of the section: the culprit is named
        try:
            _build({**values, key: val}, {**{k: where for k in values}, key: label(key)})
        except ConfigError as exc:
            msg = str(exc)
            raise ConfigError(msg if msg.startswith(label(key)) else f"{label(key)}={val!r}: {msg}") from None
    try:
        return _build({**values, **given}, {**{k: where for k in values}, **{k: label(k) for k in given}})
    except ConfigError as exc:  # valid one by one, invalid together
        opts = ", ".join(label(k) for k in given)
        raise ConfigError(f"{opts} with {where} [signal]: {exc}") from None


def settings_from_config(name_or_path: str | Path, overrides: Mapping[str, Any] | None = None,
                         option_names: Mapping[str, str] | None = None):
    """``(TESettings, ReadSettings)`` from the ``[signal]`` section of a gear configuration.

    Parameters
    ----------
    name_or_path : str or Path
        Bundled config name or TOML file (:func:`gearrom.config.load_config`).
    overrides : mapping, optional
        Values replacing the section's (same keys); None values are ignored.
    option_names : mapping, optional
        ``key -> command-line option`` named in errors caused by an override.
    """
    from gearrom.config import as_config

    cfg = as_config(name_or_path)
    return settings_from_section(cfg.section("signal"), str(cfg.source or name_or_path), overrides, option_names)
