"""A drivetrain component and a mesh excitation source are each one module: toys defined here, end to end.

* ``flywheel``: a component type of ``[[rig.components]]`` written in this file (its own
  :class:`~gearrom.rom.components.Component` subclass). Reference: the rig with the flywheel's inertia
  added to the brake rotor through the existing ``rig.load.inertia_kg_m2`` key: the same mass matrix, so
  the same modes to rounding.
* ``flat``: an excitation source of constant stiffness and zero static TE. References: the same table
  handed to :func:`~gearrom.rom.build_rig` directly (the existing route: the same run), the mean mesh
  force ``T_out / rb2`` of the statics, and no mesh-order excitation (a constant spring has none, while
  the ISO 6336 table of the same pair excites GMF lines of some um).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import pytest

from gearrom.config import from_dict, load_config
from gearrom.errors import ConfigError
from gearrom.excitation.sources import SOURCES, ExcitationSource, register_source
from gearrom.excitation.table import MeshExcitation
from gearrom.rom import build_rig, modal_analysis, simulate_run, with_overrides
from gearrom.rom.catalog import COMPONENT_TYPES, ComponentType, register_component
from gearrom.rom.components import RZ, Component, Element

pytest.importorskip("exudyn")

J_FLY = 0.03  # kg m^2
K_FLAT = 4.0e8  # N/m


# ---------------------------------------------------------------- the toy component module
@dataclass(frozen=True)
class Flywheel(Component):
    station: str
    inertia: float

    def elements(self, stations):
        return [Element(((self.station, RZ),), M=np.array([[self.inertia]]))]


FLYWHEEL = ComponentType("flywheel", {"polar_inertia_kg_m2": None},
                         lambda v, st: [Flywheel(st, v["polar_inertia_kg_m2"])], "extra rotor inertia")


# ---------------------------------------------------------------- the toy excitation source module
def flat_table(cfg, rom, torque, progress=False):
    n = 64
    torques = np.array([0.5, 1.0, 2.0]) * torque
    return MeshExcitation(z1=cfg.pair.z[0], theta=np.arange(n) * 2 * np.pi / cfg.pair.z[0] / n, torque=torques,
                          k=np.full((3, n), K_FLAT), e=np.zeros((3, n)), load_share=np.ones((3, n, 1)),
                          definition="constant stiffness (toy)", metadata={"source": "flat"})


@pytest.fixture
def toys():
    register_component(FLYWHEEL)
    register_source(ExcitationSource("flat", flat_table, lambda ex: {"k_N_per_m": K_FLAT}))
    yield
    COMPONENT_TYPES.pop("flywheel", None)
    SOURCES.pop("flat", None)


def _with_components(cfg, entries):
    raw = copy.deepcopy(dict(cfg.raw))
    raw.setdefault("rig", {})["components"] = entries
    return from_dict(raw, source=cfg.source, check=False)


def test_toy_component_equals_the_same_inertia_through_the_load_key(toys):
    base = with_overrides("thesis-rig", {"rom.excitation": "analytical"})
    with_fly = _with_components(base, [{"type": "flywheel", "station": "brake", "polar_inertia_kg_m2": J_FLY}])
    j_load = float(base.raw.get("rig", {}).get("load", {}).get("inertia_kg_m2", 0.05))
    heavier = with_overrides(base, {"rig.load.inertia_kg_m2": j_load + J_FLY})
    f_fly = modal_analysis(build_rig(with_fly), damping=False).freqs
    f_ref = modal_analysis(build_rig(heavier), damping=False).freqs
    f_base = modal_analysis(build_rig(base), damping=False).freqs
    np.testing.assert_allclose(f_fly, f_ref, rtol=1e-9)
    assert not np.allclose(f_fly[:3], f_base[:3], rtol=1e-4)  # the flywheel does move the low modes


def test_component_entries_are_checked(toys):
    base = with_overrides("thesis-rig", {"rom.excitation": "analytical"})
    bad = [({"type": "flywheel", "station": "nowhere", "polar_inertia_kg_m2": 1.0}, "station 'nowhere'"),
           ({"type": "flywheel", "station": "brake"}, "polar_inertia_kg_m2 is required"),
           ({"type": "flywheel", "station": "brake", "polar_inertia_kg_m2": -1.0}, "must be a finite number"),
           ({"type": "rocket", "station": "brake"}, "not a component type"),
           ({"type": "flywheel", "station": "brake", "polar_inertia_kg_m2": 1.0, "colour": 1}, "colour")]
    for entry, words in bad:
        with pytest.raises(ConfigError, match="rig.components\\[0\\]") as err:
            build_rig(_with_components(base, [entry]))
        assert words in str(err.value)


def test_builtin_bearing_entry_adds_its_stiffness(toys):
    """A second ball bearing at the sensor end stiffens the input shaft's lateral modes only upwards."""
    base = with_overrides("thesis-rig", {"rom.excitation": "analytical"})
    more = _with_components(base, [{"type": "ball_bearing", "station": "in.sensor_end", "radial_N_per_um": 200.0,
                                    "axial_N_per_um": 50.0}])
    f0 = modal_analysis(build_rig(base), damping=False).freqs
    f1 = modal_analysis(build_rig(more), damping=False).freqs
    assert np.all(f1 >= f0 * (1 - 1e-9)) and np.any(f1 > f0 * 1.01)  # Rayleigh: added stiffness raises modes


def test_toy_source_runs_the_rig_as_a_constant_spring(toys):
    from gearrom.rom.rig import excitation_info

    cfg = with_overrides("thesis-rig", {"rom.excitation": "flat"})
    model = build_rig(cfg)
    torque = model.metadata["torque_out_Nm"]
    run = simulate_run(model, 1000.0, duration_s=0.02)
    direct = simulate_run(build_rig(cfg, excitation=flat_table(cfg, None, torque)), 1000.0, duration_s=0.02)
    np.testing.assert_array_equal(run.delta, direct.delta)
    assert excitation_info(cfg, torque) == {"source": "flat", "torques_Nm": [0.5 * torque, torque, 2 * torque],
                                            "n_theta": 64, "k_N_per_m": K_FLAT}
    f_mean = torque / load_config("thesis-rig", check=False).pair.rb[1]
    assert np.mean(run.force) == pytest.approx(f_mean, rel=2e-3)
    iso = simulate_run(build_rig(with_overrides(cfg, {"rom.excitation": "analytical"})), 1000.0, duration_s=0.02)
    assert np.max(run.gmf_amplitudes()) < 1e-3 * np.max(iso.gmf_amplitudes())
