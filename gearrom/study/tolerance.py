"""Manufacturing deviations within the drawing tolerances (or an ISO 1328-1 grade), sampled per gear.

:class:`ToleranceSpec` holds the tolerances; :func:`sample_deviations` draws one
:class:`Deviations` per sample index from a generator seeded with ``(seed, index)``, so a sample
does not depend on how many samples the study has and a rerun draws the same values.

Distributions (all within the tolerance, every value equally likely: the study scatters over the
tolerance zone, not over a particular machine's process capability):

* single pitch deviation of each tooth: uniform in ``+-s f_pT`` with a level ``s`` uniform in
  ``[0, 1]`` per gear (so that the cumulative range scatters too, instead of a random walk of full
  steps that nearly always hits ``F_pT``), plus a once-per-revolution (long-wave) cumulative component
  of amplitude uniform in ``[0, F_pT / 2]`` and random phase; the sum is scaled down where needed so
  that every single deviation stays within ``f_pT`` and the range of the cumulative deviation within
  ``F_pT``;
* runout ``F_r`` uniform in ``[0, F_rT]``, phase uniform (eccentricity ``F_r / 2``);
* helix slope of each gear uniform in ``+-f_HbT``; the pair's slope is the sum;
* tip relief of each gear and lead crowning of the pair: nominal +- tolerance, uniform, at least 0.

Pitch deviations and runout go into the ROM as kinematic effects (:class:`gearrom.rom.mesh.Effects`,
no table change); helix slope, tip relief and crowning change the mesh excitation table
(:class:`gearrom.excitation.slices.MicroMods`). They are material removed from the flank along the
transverse line of action, as ISO 1328-1 measures profile and helix deviations and as every
micro-geometry model of the package takes them.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError
from gearrom.study.iso1328 import pair_tolerances

UM = 1e-6
#: scalar inputs of a sample, in the order of :meth:`Deviations.features` (units in the names)
FEATURES = ("runout_1_um", "runout_2_um", "cum_pitch_1_um", "cum_pitch_2_um", "single_pitch_1_um",
            "single_pitch_2_um", "helix_slope_um", "tip_relief_1_um", "tip_relief_2_um", "lead_crowning_um")
_KEYS = {"grade": "ISO 1328-1 flank tolerance class filling the keys not given",
         "f_pT_um": "[gear 1, gear 2] single pitch tolerance", "F_pT_um": "[gear 1, gear 2] cumulative pitch tolerance",
         "F_rT_um": "[gear 1, gear 2] runout tolerance", "f_HbetaT_um": "[gear 1, gear 2] helix slope tolerance",
         "tip_relief_um": "[[nominal, +-tol] gear 1, [nominal, +-tol] gear 2]",
         "lead_crowning_um": "[nominal, +-tol] of the pair"}


@dataclass(frozen=True)
class ToleranceSpec:
    """Tolerances of the pair [m]; pairs of values are (input gear, output gear).

    Attributes
    ----------
    f_pT, F_pT, F_rT, f_HbT : (float, float)
        Single pitch, cumulative pitch, runout and helix slope tolerances.
    tip_relief : ((float, float), (float, float))
        ``(nominal, +-tolerance)`` of the tip relief C_a of each gear.
    lead_crowning : (float, float)
        ``(nominal, +-tolerance)`` of the pair's lead crowning C_b.
    source : str
        Where the values come from (grade, drawing file).
    """

    f_pT: tuple[float, float]
    F_pT: tuple[float, float]
    F_rT: tuple[float, float]
    f_HbT: tuple[float, float]
    tip_relief: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    lead_crowning: tuple[float, float] = (0.0, 0.0)
    source: str = ""

    def __post_init__(self) -> None:
        vals = [*self.f_pT, *self.F_pT, *self.F_rT, *self.f_HbT, *self.tip_relief[0], *self.tip_relief[1],
                *self.lead_crowning]
        if not all(math.isfinite(v) and v >= 0 for v in vals):
            raise ConfigError(f"tolerances must be finite and >= 0 ({self.source or 'tolerance spec'})")

    @classmethod
    def from_grade(cls, pair, grade: int, tip_relief=None, lead_crowning=None) -> "ToleranceSpec":
        """ISO 1328-1:2013 tolerances of class ``grade`` for both gears of ``pair``.

        The flank modifications (``(nominal, tol)`` [m]) are not part of the standard; default: the
        nominal values recorded in the config's micro-geometry, without scatter.
        """
        t1, t2 = pair_tolerances(pair, grade)
        g = pair.gears
        tr = tip_relief or tuple((float(x.micro.tip_relief), 0.0) for x in g)
        cb = lead_crowning or (float(sum(x.micro.lead_crowning for x in g)), 0.0)
        return cls((t1.f_pT, t2.f_pT), (t1.F_pT, t2.F_pT), (t1.F_rT, t2.F_rT), (t1.f_HbT, t2.f_HbT),
                   tuple(tuple(map(float, v)) for v in tr), tuple(map(float, cb)), f"ISO 1328-1:2013 grade {grade}")

    @classmethod
    def from_toml(cls, path: str | Path, pair, grade: int | None = None) -> "ToleranceSpec":
        """Drawing tolerances from the ``[tolerance]`` table of a TOML file (keys in um, see docs/studies.md).

        Keys not given come from ISO 1328-1 class ``grade`` (the file's ``grade`` key, else the argument).

        Raises
        ------
        ConfigError
            Unreadable file, unknown key, wrong shape or a negative value (the message names the key).
        """
        path = Path(path)
        try:
            raw = tomllib.loads(path.read_text())
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read the tolerance file ({exc})") from None
        tab = raw.get("tolerance")
        if not isinstance(tab, dict):
            raise ConfigError(f"{path}: needs a [tolerance] table (keys: {', '.join(_KEYS)})")
        unknown = sorted(set(tab) - set(_KEYS))
        if unknown:
            raise ConfigError(f"{path}: unknown key 'tolerance.{unknown[0]}' (known: {', '.join(_KEYS)})")
        grade = tab.get("grade", grade)
        missing = [k for k in ("f_pT_um", "F_pT_um", "F_rT_um", "f_HbetaT_um") if k not in tab]
        if missing and grade is None:
            raise ConfigError(f"{path}: tolerance.{missing[0]} is missing and no grade is given to fill it")
        try:
            base = cls.from_grade(pair, grade) if grade is not None else None
        except ConfigError as exc:
            raise ConfigError(f"{path}: tolerance.grade: {exc}") from None

        def pair_of(key: str, shape: tuple) -> tuple:
            v = tab[key]
            arr = np.asarray(v, dtype=object)
            ok = arr.shape == shape and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                            and math.isfinite(x) and x >= 0 for x in arr.ravel())
            if not ok:
                raise ConfigError(f"{path}: tolerance.{key} must be {_KEYS[key]} of numbers >= 0 [um], got {v!r}")
            return tuple(map(tuple, np.asarray(v, float) * UM)) if len(shape) == 2 else tuple(np.asarray(v, float) * UM)

        f = {}
        for key, attr in (("f_pT_um", "f_pT"), ("F_pT_um", "F_pT"), ("F_rT_um", "F_rT"), ("f_HbetaT_um", "f_HbT")):
            f[attr] = pair_of(key, (2,)) if key in tab else getattr(base, attr)
        tr = pair_of("tip_relief_um", (2, 2)) if "tip_relief_um" in tab else \
            (base.tip_relief if base else ((0.0, 0.0), (0.0, 0.0)))
        cb = pair_of("lead_crowning_um", (2,)) if "lead_crowning_um" in tab else \
            (base.lead_crowning if base else (0.0, 0.0))
        src = f"drawing tolerances {path.name}" + (f" (missing keys: ISO 1328-1:2013 grade {grade})" if missing else "")
        return cls(**f, tip_relief=tr, lead_crowning=cb, source=src)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Deviations:
    """One sample of manufacturing deviations [m, rad]; pairs are (input gear, output gear)."""

    index: int
    pitch: tuple[tuple[float, ...], tuple[float, ...]]
    runout: tuple[float, float]
    runout_phase: tuple[float, float]
    helix_slope: float
    tip_relief: tuple[float, float]
    lead_crowning: float
    extra: dict = field(default_factory=dict, compare=False)

    def effects(self):
        """Runout and pitch deviations as ROM kinematic effects."""
        from gearrom.rom.mesh import Effects, PitchDeviations, Runout

        run = tuple(Runout(i, 0.5 * self.runout[i], self.runout_phase[i]) for i in range(2) if self.runout[i] > 0)
        pit = tuple(PitchDeviations(i, tuple(self.pitch[i])) for i in range(2) if any(self.pitch[i]))
        return Effects(runout=run, pitch=pit)

    def mods(self):
        """Flank modifications of the sample (changes the mesh excitation table)."""
        from gearrom.excitation.slices import MicroMods

        return MicroMods(tip_relief=tuple(self.tip_relief), lead_crowning=self.lead_crowning,
                         helix_slope=self.helix_slope)

    def features(self) -> np.ndarray:
        """Scalar inputs in the order of :data:`FEATURES` [um]."""
        cum = [float(np.ptp(np.cumsum(np.asarray(p) - np.mean(p)))) if len(p) else 0.0 for p in self.pitch]
        single = [float(np.max(np.abs(p))) if len(p) else 0.0 for p in self.pitch]
        return np.array([*self.runout, *cum, *single, self.helix_slope, *self.tip_relief, self.lead_crowning]) / UM

    def to_json(self) -> dict:
        d = asdict(self)
        d.pop("extra")
        return d


def _pitch(rng: np.random.Generator, z: int, f_pt: float, f_p: float) -> np.ndarray:
    if f_pt <= 0 and f_p <= 0:
        return np.zeros(z)
    j = np.arange(z + 1)
    long = 0.5 * f_p * rng.uniform() * np.sin(2 * np.pi * j / z + rng.uniform(0, 2 * np.pi))
    level = rng.uniform()
    fp = level * rng.uniform(-f_pt, f_pt, z) + np.diff(long)
    scale = 1.0
    if f_pt > 0 and np.max(np.abs(fp)) > f_pt:
        scale = f_pt / np.max(np.abs(fp))
    rng_cum = float(np.ptp(np.cumsum(fp - fp.mean())))
    if rng_cum * scale > f_p:
        scale = f_p / rng_cum
    return fp * scale


def sample_deviations(spec: ToleranceSpec, z: tuple[int, int], index: int, seed: int = 0) -> Deviations:
    """Draw sample ``index`` of the study seeded with ``seed`` (see module docstring)."""
    rng = np.random.default_rng([int(seed), int(index)])
    pitch = tuple(tuple(_pitch(rng, z[i], spec.f_pT[i], spec.F_pT[i]).tolist()) for i in range(2))
    runout = tuple(float(rng.uniform(0, spec.F_rT[i])) for i in range(2))
    phase = tuple(float(rng.uniform(0, 2 * np.pi)) for i in range(2))
    slope = float(sum(rng.uniform(-spec.f_HbT[i], spec.f_HbT[i]) for i in range(2)))
    tr = tuple(max(0.0, float(n + rng.uniform(-t, t))) for n, t in spec.tip_relief)
    n, t = spec.lead_crowning
    cb = max(0.0, float(n + rng.uniform(-t, t)))
    return Deviations(int(index), pitch, runout, phase, slope, tr, cb)
