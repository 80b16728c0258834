"""Settings of the measurement reader and the edge checks (:class:`ReadSettings`), the gear data the TE
needs (:class:`GearMeshInfo`) and the settings of the TE processing (:class:`TESettings`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from gearrom.errors import ConfigError
from gearrom.signal.filters import FilterSettings


@dataclass(frozen=True)
class ReadSettings:
    """Settings of the reader and the edge checks.

    Parameters
    ----------
    fs_hz : float or None
        Rate of the common time grid in Hz. None: the slower channel's nominal edge rate, divided
        by the smallest integer that brings it to at most ``fs_max_hz``.
    fs_max_hz : float
        Upper limit of the automatic grid rate, Hz.
    chunk_rows : int
        Rows read per chunk (memory is proportional to it).
    double_ratio, gap_ratio : float
        Interval/reference below which an edge is spurious, above which edges were dropped.
    integer_tol : float
        Largest distance of the interval/reference ratio from an integer m for a gap to count as
        m - 1 dropped edges.
    max_fill_edges : int
        Most consecutive dropped edges that are filled; longer gaps are errors.
    max_repairs : int
        More repairs than this per channel is an error (the data are not trustworthy).
    rpm_tolerance : float
        Allowed relative difference between ``rpm_in`` of the metadata and the measured speed.
    strict : bool
        Treat every repair as an error.
    edge_interp : {"linear", "cubic"}
        Angle between edges: a cubic Hermite through the edges with centred-difference slopes
        (default; error O(h^3)), or linear (O(h^2): a TE component with p edges per period on the
        channel that carries it is attenuated by sinc^2(pi/p) ~ 1 - (2 pi/p)^2/12).
    max_grid_samples : int
        Most samples of the common time grid per channel (8 bytes each). A grid rate far above
        the edge rate, or an overlong record, is an error instead of an allocation that exhausts
        the memory.
    allow_outside_data : bool
        Read a data file outside the measurement JSON's folder tree (refused by default).
    timing_resolution_s : float or None
        Timing resolution of the edge times, s: an interval within twice this of its reference is
        never repaired. None: ``1/clock_hz`` (kind ``edges``) or the sample step (``quadrature``).
    edge_period : int or None
        Edges per decoding period whose intervals are compared (4 for x4 decoding, whose A/B phase
        error makes neighbouring intervals unequal). None: the decoding factor of kind
        ``quadrature``, 1 for kind ``edges``.
    t_start_s, t_end_s : float or None
        Time window of the record that is used, s (None: from the start / to the end).
    trim : bool
        Kind ``quadrature``, and kind ``edges`` with a ``direction`` column: cut standstill,
        jitter and reversals before and after the longest stretch of forward rotation (reported);
        False: a reversal is an error.
    min_speed_fraction : float
        Standstill for trimming: no new edge for longer than the edge interval at this fraction of
        the record's highest speed.
    """

    fs_hz: float | None = None
    fs_max_hz: float = 200e3
    chunk_rows: int = 2_000_000
    double_ratio: float = 0.5
    gap_ratio: float = 1.5
    integer_tol: float = 0.3
    max_fill_edges: int = 64
    max_repairs: int = 1000
    rpm_tolerance: float = 0.05
    strict: bool = False
    edge_interp: Literal["linear", "cubic"] = "cubic"
    max_grid_samples: int = 100_000_000
    allow_outside_data: bool = False
    timing_resolution_s: float | None = None
    edge_period: int | None = None
    t_start_s: float | None = None
    t_end_s: float | None = None
    trim: bool = True
    min_speed_fraction: float = 0.05

    def __post_init__(self):
        for name in ("timing_resolution_s", "t_start_s", "t_end_s"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                                      and (v >= 0 if name != "timing_resolution_s" else v > 0)):
                raise ConfigError(f"Parameter {name}={v!r} must be a finite number "
                                  f"{'> 0' if name == 'timing_resolution_s' else '>= 0'} or None")
        if self.t_start_s is not None and self.t_end_s is not None and not self.t_end_s > self.t_start_s:
            raise ConfigError(f"Parameter t_end_s={self.t_end_s!r} must be > t_start_s={self.t_start_s!r}")
        if self.edge_period is not None and (isinstance(self.edge_period, bool) or self.edge_period not in (1, 2, 4)):
            raise ConfigError(f"Parameter edge_period={self.edge_period!r} must be 1, 2 or 4 or None")
        if not (isinstance(self.min_speed_fraction, (int, float)) and 0 < self.min_speed_fraction < 1):
            raise ConfigError(f"Parameter min_speed_fraction={self.min_speed_fraction!r} must lie in (0, 1)")
        if not (isinstance(self.integer_tol, (int, float)) and 0 < self.integer_tol < 0.5):
            raise ConfigError(f"Parameter integer_tol={self.integer_tol!r} must lie in (0, 0.5)")
        for name in ("max_fill_edges", "max_repairs"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ConfigError(f"Parameter {name}={v!r} must be an integer >= 0")
        if self.fs_hz is not None and not (isinstance(self.fs_hz, (int, float)) and math.isfinite(self.fs_hz)
                                           and self.fs_hz > 0):
            raise ConfigError(f"Parameter fs_hz={self.fs_hz!r} must be a finite number > 0 or None")
        if not (isinstance(self.fs_max_hz, (int, float)) and math.isfinite(self.fs_max_hz) and self.fs_max_hz > 0):
            raise ConfigError(f"Parameter fs_max_hz={self.fs_max_hz!r} must be a finite number > 0")
        if not (isinstance(self.rpm_tolerance, (int, float)) and math.isfinite(self.rpm_tolerance)
                and self.rpm_tolerance > 0):
            raise ConfigError(f"Parameter rpm_tolerance={self.rpm_tolerance!r} must be a finite number > 0")
        if isinstance(self.max_grid_samples, bool) or not isinstance(self.max_grid_samples, int) \
                or self.max_grid_samples < 16:
            raise ConfigError(f"Parameter max_grid_samples={self.max_grid_samples!r} must be an integer >= 16")
        if not (0 < self.double_ratio < 1 < self.gap_ratio):
            raise ConfigError(f"need 0 < double_ratio={self.double_ratio} < 1 < gap_ratio={self.gap_ratio}")
        if self.chunk_rows < 16:
            raise ConfigError(f"Parameter chunk_rows={self.chunk_rows} must be >= 16")
        if self.edge_interp not in ("linear", "cubic"):
            raise ConfigError(f"Parameter edge_interp={self.edge_interp!r} must be 'linear' or 'cubic'")


DEFAULT_CONFIG = "thesis-helical"


@dataclass(frozen=True)
class GearMeshInfo:
    """What the TE needs to know about the gear pair (the measurement file does not carry it).

    Parameters
    ----------
    z1, z2 : int
        Teeth of the input (driving) and output gear.
    rb1_m, rb2_m : float
        Base radii, m.
    r1_m, r2_m : float
        Pitch (reference) radii, m.
    name : str
        Where the data came from (config name), informative.
    """

    z1: int
    z2: int
    rb1_m: float
    rb2_m: float
    r1_m: float
    r2_m: float
    name: str = ""

    def __post_init__(self):
        for k in ("z1", "z2"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ConfigError(f"GearMeshInfo: {k}={v!r} must be an integer >= 1")
        for k in ("rb1_m", "rb2_m", "r1_m", "r2_m"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 < v < 10):
                raise ConfigError(f"GearMeshInfo: {k}={v!r} must be a radius in m (0 < r < 10)")

    @classmethod
    def from_config(cls, name_or_path=DEFAULT_CONFIG, name: str | None = None) -> GearMeshInfo:
        """Take teeth, base and pitch radii from a gear configuration (a loaded ``GearConfig``, a bundled
        name or a path: :func:`gearrom.config.as_config`)."""
        from gearrom.config import GearConfig, as_config

        cfg = as_config(name_or_path)
        pair = cfg.pair
        (z1, z2), (db1, db2), (d1, d2) = pair.z, pair.db, pair.d
        if name is None:
            name = cfg.name if isinstance(name_or_path, GearConfig) else str(name_or_path)
        return cls(int(z1), int(z2), db1 / 2, db2 / 2, d1 / 2, d2 / 2, name=name)

    @property
    def ratio(self) -> float:
        """Nominal speed ratio n_out/n_in = z1/z2."""
        return self.z1 / self.z2

    @property
    def hunting_revs_in(self) -> int:
        """Input revolutions of one hunting-tooth period, z2/gcd(z1, z2)."""
        return self.z2 // math.gcd(self.z1, self.z2)

    def radii(self, te_on: Literal["line", "pitch"]) -> tuple[float, float]:
        """``(r_in, r_out)`` the TE is taken on: base radii for ``"line"``, pitch radii for ``"pitch"``."""
        if te_on == "line":
            return self.rb1_m, self.rb2_m
        if te_on == "pitch":
            return self.r1_m, self.r2_m
        raise ConfigError(f"te_on={te_on!r} must be 'line' or 'pitch'")


@dataclass(frozen=True)
class TESettings:
    """Settings of the TE processing.

    Parameters
    ----------
    te_on : {"line", "pitch"}
        Line of action (base radii) or pitch circle (seed eq. 38-40).
    filters : FilterSettings
        Detrend / high-pass / Bessel low-pass.
    samples_per_rev : int or None
        Angle-grid points per input revolution for order spectra and averages (None: a power of two
        at least as dense as the time grid, minimum 256).
    window : str
        Window of the time-domain amplitude spectrum.
    ratio_tolerance : float
        Allowed relative difference of the measured speed ratio from z1/z2.
    n_harmonics, n_sidebands : int
        GMF harmonics and shaft-order sidebands annotated.
    estimate_scale : {"none", "input", "output"}
        Estimate the counts per shaft revolution of this encoder from the measured speed ratio
        (instead of the ratio check) and correct its angle.
    """

    te_on: Literal["line", "pitch"] = "line"
    filters: FilterSettings = field(default_factory=FilterSettings)
    samples_per_rev: int | None = None
    window: str = "hann"
    ratio_tolerance: float = 0.005
    n_harmonics: int = 3
    n_sidebands: int = 2
    estimate_scale: Literal["none", "input", "output"] = "none"

    def __post_init__(self):
        if self.estimate_scale not in ("none", "input", "output"):
            raise ConfigError(f"estimate_scale={self.estimate_scale!r} must be 'none', 'input' or 'output'")
        if self.te_on not in ("line", "pitch"):
            raise ConfigError(f"te_on={self.te_on!r} must be 'line' or 'pitch'")
        if self.samples_per_rev is not None and self.samples_per_rev < 8:
            raise ConfigError(f"samples_per_rev={self.samples_per_rev!r} must be >= 8 or None")
