"""Input dataclasses for one gear: material, rack tool, micro-geometry, gear blank.

All values are SI (m, rad, Pa, kg/m^3). Configs in mm/um are converted in
:mod:`gearrom.config`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from gearrom.errors import ConfigError

Hand = Literal["right", "left", "spur"]

#: Fewest teeth accepted: fewer are outside involute gear practice (undercut or pointed teeth).
MIN_TEETH = 5
#: Most teeth accepted: beyond any cylindrical gear, so a larger count is a typing or unit mistake.
#: The excitation tables and the sweep sample every mesh period, so their cost grows with z.
MAX_TEETH = 1000


def _positive(owner: str, **values: float | None) -> None:
    """Raise when a length (keyword ``NAME_mm``, value in m) is not positive; the message shows mm."""
    for name, value in values.items():
        if value is not None and not (value > 0 and math.isfinite(value)):
            shown = value * 1e3 if name.endswith("_mm") else value
            unit = " mm" if name.endswith("_mm") else ""
            raise ConfigError(f"{owner}.{name} must be a positive finite number, got {shown:g}{unit}")


@dataclass(frozen=True)
class Material:
    """Linear elastic material.

    Parameters
    ----------
    youngs_modulus : float
        Young's modulus E [Pa].
    poisson_ratio : float
        Poisson's ratio nu [-], in (-1, 0.5).
    density : float
        Mass density rho [kg/m^3].
    """

    youngs_modulus: float = 210e9
    poisson_ratio: float = 0.3
    density: float = 7850.0

    def __post_init__(self) -> None:
        if not (self.youngs_modulus > 0 and math.isfinite(self.youngs_modulus)):
            raise ConfigError(f"material.youngs_modulus_GPa must be positive, got {self.youngs_modulus / 1e9:g}")
        _positive("material", density_kg_per_m3=self.density)
        if not -1.0 < self.poisson_ratio < 0.5:
            raise ConfigError(f"material.poisson_ratio must lie in (-1, 0.5), got {self.poisson_ratio!r}")

    @property
    def plane_strain_modulus(self) -> float:
        """E / (1 - nu^2) [Pa]."""
        return self.youngs_modulus / (1.0 - self.poisson_ratio**2)


@dataclass(frozen=True)
class RackTool:
    """Generating rack (hob) data in the normal section.

    Parameters
    ----------
    addendum : float or None
        Tool addendum h_aP0 [m] (cuts the root). ``None``: derived from the gear's root
        diameter if that is given, else from its dedendum coefficient.
    tip_radius : float or None
        Tool tip radius rho_aP0 [m]. ``None``: 0.38 m_n (ISO 53 profile A).
    protuberance : float
        Protuberance amount pr_P0 [m] (recorded; used by the profile generator).
    protuberance_angle : float
        Protuberance flank angle alpha_prP0 [rad].
    """

    addendum: float | None = None
    tip_radius: float | None = None
    protuberance: float = 0.0
    protuberance_angle: float = math.radians(10.0)

    def __post_init__(self) -> None:
        _positive("tool", addendum_mm=self.addendum)
        if self.tip_radius is not None and not (self.tip_radius >= 0 and math.isfinite(self.tip_radius)):
            raise ConfigError(f"tool.tip_radius_mm must be >= 0, got {self.tip_radius * 1e3:g} mm")
        if not (self.protuberance >= 0 and math.isfinite(self.protuberance)):
            raise ConfigError(f"tool.protuberance_mm must be >= 0, got {self.protuberance * 1e3:g} mm")


@dataclass(frozen=True)
class MicroGeometry:
    """Flank modifications and manufacturing errors of one gear (SI, lengths in m).

    Profile and lead modifications and deviations are material removed from the flank, measured in the
    transverse plane along the base tangent (the transverse line of action), as ISO 1328-1 measures
    profile and helix deviations; along the flank normal of a helical gear they are ``cos(beta_b)``
    times these values.

    Parameters
    ----------
    enabled : bool
        When False the gear is treated as perfect (the values stay available).
    tip_relief : float
        Linear tip relief C_a [m] at the tip.
    tip_relief_start_diameter : float or None
        Diameter d_Ca where the relief starts [m].
    profile_crowning : float
        Profile (height) crowning C_H [m], parabolic over the active profile.
    lead_crowning : float
        Lead crowning C_b [m], parabolic over the face width.
    helix_slope : float
        Helix slope deviation f_Hbeta [m] over the face width (misalignment).
    profile_slope : float
        Profile slope deviation f_Halpha [m] over the active profile.
    pitch_deviations : tuple of float
        Single pitch deviation f_p of each tooth [m] (empty, or one per tooth).
    runout : float
        Radial runout F_r [m] (twice the geometric eccentricity).
    runout_phase : float
        Angle of the largest radial position, from tooth 0 [rad].
    tip_form_diameter : float or None
        Tip form diameter d_Na [m] where a tip chamfer / edge break begins.
    """

    enabled: bool = False
    tip_relief: float = 0.0
    tip_relief_start_diameter: float | None = None
    profile_crowning: float = 0.0
    lead_crowning: float = 0.0
    helix_slope: float = 0.0
    profile_slope: float = 0.0
    pitch_deviations: tuple[float, ...] = ()
    runout: float = 0.0
    runout_phase: float = 0.0
    tip_form_diameter: float | None = None

    def __post_init__(self) -> None:
        for name in ("tip_relief", "profile_crowning", "lead_crowning", "runout"):
            value = getattr(self, name)
            if value < 0 or not math.isfinite(value):
                raise ConfigError(f"microgeometry.{name}_um must be >= 0, got {value * 1e6:g} um")
        if self.tip_relief > 0 and self.tip_relief_start_diameter is None:
            raise ConfigError("microgeometry.tip_relief_start_diameter_mm is required when tip_relief_um > 0")

    @property
    def eccentricity(self) -> float:
        """Geometric eccentricity e = F_r / 2 [m]."""
        return 0.5 * self.runout


@dataclass(frozen=True)
class Gear:
    """One external cylindrical gear (spur or helical).

    Parameters
    ----------
    name : str
        ``"input_gear"`` or ``"output_gear"`` (any label).
    z : int
        Number of teeth.
    x : float
        Profile shift coefficient [-].
    hand : {"right", "left", "spur"}
        Helix hand.
    face_width : float
        Face width b [m].
    bore_diameter : float
        Bore diameter [m].
    addendum_coefficient, dedendum_coefficient : float
        h_a* and h_f* of the basic rack [-].
    tip_diameter, root_diameter : float or None
        Explicit d_a and d_f [m] as on drawings (override the coefficients).
    root_form_diameter : float or None
        Root form diameter d_Ff [m] from the drawing (else derived from the tool).
    tip_edge_radius : float
        Radius of the rounded tip edge [m] (0: sharp).
    material, tool, micro
        See :class:`Material`, :class:`RackTool`, :class:`MicroGeometry`.
    """

    name: str
    z: int
    face_width: float
    bore_diameter: float
    x: float = 0.0
    hand: Hand = "spur"
    addendum_coefficient: float = 1.0
    dedendum_coefficient: float = 1.25
    tip_diameter: float | None = None
    root_diameter: float | None = None
    root_form_diameter: float | None = None
    tip_edge_radius: float = 0.0
    material: Material = field(default_factory=Material)
    tool: RackTool = field(default_factory=RackTool)
    micro: MicroGeometry = field(default_factory=MicroGeometry)

    def __post_init__(self) -> None:
        owner = self.name
        if not isinstance(self.z, int) or isinstance(self.z, bool) or not MIN_TEETH <= self.z <= MAX_TEETH:
            raise ConfigError(f"{owner}.teeth must be an integer in [{MIN_TEETH}, {MAX_TEETH}], got {self.z!r}")
        _positive(
            owner,
            face_width_mm=self.face_width,
            bore_diameter_mm=self.bore_diameter,
            tip_diameter_mm=self.tip_diameter,
            root_diameter_mm=self.root_diameter,
            root_form_diameter_mm=self.root_form_diameter,
            tip_edge_radius_mm=self.tip_edge_radius or None,
            addendum_coefficient=self.addendum_coefficient,
            dedendum_coefficient=self.dedendum_coefficient,
        )
        if self.hand not in ("right", "left", "spur"):
            raise ConfigError(f"{owner}.hand must be 'right', 'left' or 'spur', got {self.hand!r}")
        if not -1.5 < self.x < 2.0:
            raise ConfigError(f"{owner}.profile_shift must lie in (-1.5, 2.0), got {self.x!r}")
        pd = self.micro.pitch_deviations
        if pd and len(pd) != self.z:
            raise ConfigError(
                f"{owner}.microgeometry.pitch_deviations_um has {len(pd)} entries; it needs one per tooth ({self.z})"
            )
