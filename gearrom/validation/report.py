"""ROM vs explicit FE at given input speeds: stored FE records, the matching pair ROM, the report.

Stored FE records (written by ``validation/run_explicit_spur.py`` and, for helical pairs in 3D,
``validation/run_explicit_helical.py``): ``spur_<rpm>rpm.npz`` / ``helical_<rpm>rpm.npz`` with
``t_s``, ``te_m``, ``theta_rad`` (rotation of the two rigid bore references, rad) and the matching
``.json`` with at least ``t_steady_from_s``, ``torque_out_Nm``, ``ramp_s``, ``outline_size_mm``,
``body_size_mm``, ``wall_s``, ``t_end_s``.

Helical pairs: the ROM is the same 1-DOF pair model on the transverse line of action with the
helical mesh table (the slice LTCA of :mod:`gearrom.fe.ltca_slices` by default, whose phase origin is
the mid-face section, as the 3D FE's start position); the output inertia is the transverse mesh's
polar inertia times the common face width (the extruded mesh's); no faceted-outline kinematic TE
(the 3D FE's outline nodes lie on the generated profile; its per-layer rigid slack is in the record).
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError
from gearrom.spectral import spectrum
from gearrom.validation.compare import PERIODIC_ORDERS, TOLERANCES, compare_metrics, steady_window, te_metrics
from gearrom.validation.gates import record_gates
from gearrom.validation.pair_rom import (REFERENCE_SLICES, PairRomSetup, mesh_excitation, polar_inertia,
                                         reference_settings, scaled_excitation, simulate_pair_rom, table_samples)
from gearrom.validation.records import (DEFAULT_FE_DIR, FE_INTEGRATIONS, FERecord, check_record_pair, load_fe_record,
                                        record_prefix, record_stem, replace_meta)

log = logging.getLogger(__name__)

__all__ = ["DEFAULT_FE_DIR", "FERecord", "ValidationReport", "fe_damping_ratio", "load_fe_record", "record_stem",
           "output_inertia", "replace_meta", "validate_speed", "validate"]


def output_inertia(pair, outline_size: float, body_size: float, grading: float | None = None,
                   project: bool = False) -> tuple[float, str]:
    """Polar inertia of the output gear from the explicit FE's own mesh (same sizes, m; ``project``: outline
    nodes on the profile, :func:`gearrom.fe.explicit.gearmesh.gear_quad_mesh`), and a label."""
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh

    kw = {} if grading is None else {"grading": grading}
    nodes, quads, _ = gear_quad_mesh(pair, 1, outline_size, body_size, project=project, **kw)
    g = pair.gears[1]
    j = polar_inertia(nodes, quads, (0.0, 0.0), g.material.density, min(pair.gears[0].face_width, g.face_width))
    return j, f"rho b int r^2 dA over the FE output-gear quad mesh ({outline_size * 1e3:g}/{body_size * 1e3:g} mm)"


def gear_bodies(pair, outline_size: float, body_size: float, grading: float | None = None,
                project: bool = False) -> tuple:
    """The rim-on-hub body models (:func:`gearrom.fe.bodies.gear_body`) of both gears from the explicit FE's own
    transverse meshes (sizes as :func:`output_inertia`)."""
    from gearrom.fe.bodies import gear_body
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh

    kw = {} if grading is None else {"grading": grading}
    width = min(g.face_width for g in pair.gears)
    out = []
    for i, g in enumerate(pair.gears):
        nodes, quads, bore = gear_quad_mesh(pair, i, outline_size, body_size, project=project, **kw)
        out.append(gear_body(nodes, quads, bore, width, E=g.material.youngs_modulus, nu=g.material.poisson_ratio,
                             density=g.material.density))
    return tuple(out)


def fresh_fe_record(pair, rpm: float, torque: float, outline: float = 0.3e-3, body: float = 2e-3,
                    ramp: float = 0.3e-3, settle_periods: int = 1, periods: int = 3) -> FERecord:
    """Run a coarse explicit FE of the pair now (minutes): same set-up as the stored runs, coarser mesh."""
    import time

    from gearrom.fe.explicit.gearmesh import gear_quad_mesh
    from gearrom.fe.explicit.gearpair import GearPairSetup, run_gear_pair

    meshes = [gear_quad_mesh(pair, i, outline, body) for i in (0, 1)]
    f_mesh = rpm / 60 * pair.z[0]
    t_end = ramp + (settle_periods + periods) / f_mesh
    setup = GearPairSetup(rpm_in=rpm, torque_out=torque, torque_ramp_time=ramp, mu=0.0)
    t0 = time.perf_counter()
    res, te, _ = run_gear_pair(pair, meshes, setup, t_end=t_end, sample_period=1.0 / (f_mesh * 128))
    meta = {"t_steady_from_s": ramp + settle_periods / f_mesh, "torque_out_Nm": torque, "ramp_s": ramp,
            "outline_on_profile": True,
            "outline_size_mm": outline * 1e3, "body_size_mm": body * 1e3, "t_end_s": t_end,
            "wall_s": time.perf_counter() - t0, "dt_s": res.meta.get("dt_s"), "mu": 0.0,
            "hourglass_ratio": res.hourglass_ratio}
    return FERecord(t=res.t, theta_in=res.theta[:, 0] - res.theta[0, 0], te=te, meta=meta, source="fresh")


@dataclass(frozen=True, eq=False)
class SpeedComparison:
    """ROM and FE records at one speed, their metrics and the verdict."""

    rpm_in: float
    fe: FERecord
    rom_t: np.ndarray
    rom_theta_in: np.ndarray
    rom_te: np.ndarray
    rom_meta: dict
    metrics: dict
    passed: bool
    misses: list
    fe_window: np.ndarray
    rom_window: np.ndarray
    gates: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"rpm_in": self.rpm_in, "fe_source": self.fe.source, "metrics": self.metrics, "passed": self.passed,
                "misses": self.misses, "tolerances": TOLERANCES, "gates": self.gates,
                "noise_floor_um": self.gates.get("noise_floor_um"),
                "fe": {k: self.fe.meta.get(k) for k in ("record", "integration", "start", "outline_size_mm",
                                                        "body_size_mm", "dt_s", "n_elements", "wall_s", "t_end_s",
                                                        "hourglass_ratio", "energy_error", "mu", "zeta_target",
                                                        "relative_damping_per_s", "settle_periods")},
                "rom": {k: v for k, v in self.rom_meta.items() if k != "excitation_definition"}}


#: results of :func:`facet_kinematic_te` computed in this process, by a digest of everything they depend on
_FACET_TE: dict[str, np.ndarray] = {}


def facet_kinematic_te(pair, excitation, torque: float, outline: float, body: float, theta_end: float,
                       per_period: int = 32, project: bool = False) -> tuple[float, np.ndarray]:
    """Kinematic TE of the FE's faceted outlines over input angles 0..theta_end: (step [rad], values [m]).

    ``project``: the FE mesh has its outline nodes on the profile (:func:`gear_quad_mesh`). The result is
    kept for the process, keyed by the pair, the mesh sizes, the angles and the table rows it uses (load
    shares, stiffness, pair labels), so that comparisons of one record with several ROMs or records of one
    length compute it once; a copy is returned."""
    import hashlib

    from gearrom.fe.explicit.gearmesh import gear_quad_mesh
    from gearrom.validation.facets import faceted_rigid_te, share_rows
    from gearrom.validation.pair_rom import fe_start_mesh_phase

    period = 2 * math.pi / pair.z[0]
    step = period / per_period
    th = np.arange(0.0, theta_end + 2 * step, step)
    phase0 = fe_start_mesh_phase(pair)
    j = int(np.argmin(np.abs(np.asarray(excitation.torque) - torque)))
    share_tab = np.asarray(excitation.load_share)[j]                       # (n_theta, n_pairs)
    k = np.asarray(excitation.stiffness(np.mod(phase0 + th, period), torque), float)
    share = share_rows(share_tab, phase0 + th, period)
    pairs = getattr(excitation, "pairs", None)
    digest = hashlib.sha256(repr((pair, float(torque), float(outline), float(body), bool(project), phase0)).encode())
    for a in (th, share, k, np.asarray([] if pairs is None else pairs, float)):
        digest.update(np.ascontiguousarray(a, float).tobytes())
    key = digest.hexdigest()
    if key not in _FACET_TE:
        meshes = [gear_quad_mesh(pair, i, outline, body, project=project) for i in (0, 1)]
        if len(_FACET_TE) >= 8:
            _FACET_TE.clear()
        _FACET_TE[key] = faceted_rigid_te(pair, meshes, th, share, phase0, force=torque / pair.rb[1], stiffness=k,
                                          pairs=pairs)
    return step, _FACET_TE[key].copy()


def validate_speed(pair, rpm: float, fe: FERecord, excitation, excitation_label: str, inertia_out: float,
                   inertia_label: str, damping_ratio: float = 0.01,
                   kinematic: tuple[float, np.ndarray] | None = None,
                   table_provenance: dict | None = None, rom_model: str = "pair",
                   bodies: tuple | None = None) -> SpeedComparison:
    """Run the pair ROM for the FE record's set-up and compare both on the FE's steady window.

    ``rom_model``: ``"pair"`` (the 1-DOF RK4 model of :mod:`gearrom.validation.pair_rom`, with the FE's
    torque ramp) or ``"exudyn"`` (the same system as an exudyn Drivetrain through
    :func:`gearrom.rom.simulate.simulate_run`, :mod:`gearrom.validation.pair_exudyn`; starts at full
    torque from the periodic state) or ``"exudyn-bodies"`` (that Drivetrain with flexible gear bodies ``bodies``,
    :func:`gearrom.validation.pair_exudyn.body_drivetrain`). The diagnostics below always use the pair ROM.

    ``kinematic``: optional (step, values) kinematic TE over the input angle (the FE outline facets).
    ``table_provenance``: where the mesh table came from (written to the ROM metadata as ``table``).
    """
    z1 = pair.z[0]
    f_mesh = rpm / 60 * z1
    torque = float(fe.meta["torque_out_Nm"])
    ramp = float(fe.meta.get("ramp_s", 0.3e-3))
    setup = PairRomSetup(rpm_in=rpm, torque_out=torque, torque_ramp_time=ramp, inertia_out=inertia_out,
                         damping_ratio=damping_ratio)
    if rom_model not in ROM_MODELS:
        raise ConfigError(f"rom_model must be one of {ROM_MODELS}, got {rom_model!r}")
    span = {"t_end": float(fe.t[-1]), "sample_period": 1.0 / (f_mesh * 128)}
    if rom_model in ("exudyn", "exudyn-bodies"):
        from gearrom.validation.pair_exudyn import pair_drivetrain, simulate_pair_exudyn

        if rom_model == "exudyn-bodies" and bodies is None:
            raise ConfigError("rom_model 'exudyn-bodies' needs the gear bodies")
        model = pair_drivetrain(pair, excitation, setup, bodies=bodies if rom_model == "exudyn-bodies" else None)
        rom = simulate_pair_exudyn(pair, excitation, setup, kinematic=kinematic, model=model, **span)
    else:
        rom = simulate_pair_rom(pair, excitation, setup, kinematic=kinematic, **span)
    t_from = float(fe.meta["t_steady_from_s"])
    wf = steady_window(fe.theta_in, fe.t, t_from, z1)
    wr = steady_window(rom.theta_in, rom.t, t_from, z1)
    m_fe = te_metrics(fe.theta_in[wf], fe.te[wf], z1)
    m_rom = te_metrics(rom.theta_in[wr], rom.te[wr], z1)
    gates = record_gates(fe.theta_in[wf], fe.te[wf], z1, fe.energies)
    floor = gates["noise_floor_um"]
    metrics, passed, misses = compare_metrics(m_rom, m_fe, floor_um=floor)
    if not gates["passed"]:
        misses = misses + [f"FE record gate {g}: {gates[g]:.3g} >= {gates['limits'][g]:g} (not a reference)"
                           for g in gates["failed"]]
        passed = False
    meta = dict(rom.meta, rom_model=rom_model, excitation=excitation_label, inertia_source=inertia_label,
                mesh_periods=m_rom["mesh_periods"],
                table=table_provenance or {"table": "ltca"},
                geometry=("ideal involute + FE outline facets (per-pair rigid gaps, loaded pairs by stiffness share)" if kinematic is not None
                          else "ideal involute (mesh table only)"))
    if kinematic is not None:       # diagnostic: the ROM of the ideal involute (mesh table only)
        rom_i = simulate_pair_rom(pair, excitation, setup, **span)
        wi = steady_window(rom_i.theta_in, rom_i.t, t_from, z1)
        m_i, passed_i, misses_i = compare_metrics(te_metrics(rom_i.theta_in[wi], rom_i.te[wi], z1), m_fe, floor_um=floor)
        meta["diagnostic_ideal_involute"] = {"metrics": m_i, "would_pass": passed_i, "misses": misses_i}
    # diagnostic (not part of the verdict): the same ROM with its mesh stiffness scaled so that the mean
    # elastic deflection equals the FE's, i.e. how much of the difference is the stiffness level
    k_tab, e_tab = table_samples(pair, excitation, torque)
    e0_mean = float(e_tab.mean()) - torque / pair.rb[1] / float(k_tab.mean())
    scale = (m_rom["te_mean_um"] * 1e-6 - e0_mean) / (m_fe["te_mean_um"] * 1e-6 - e0_mean)
    if scale > 0 and math.isfinite(scale):
        ex_s = scaled_excitation(replace_meta(excitation, rb2_m=pair.rb[1]), torque, scale)
        rom_s = simulate_pair_rom(pair, ex_s, setup, kinematic=kinematic, **span)
        ws = steady_window(rom_s.theta_in, rom_s.t, t_from, z1)
        m_s, passed_s, misses_s = compare_metrics(te_metrics(rom_s.theta_in[ws], rom_s.te[ws], z1), m_fe, floor_um=floor)
        meta["diagnostic_stiffness_matched"] = {"stiffness_scale": scale, "metrics": m_s, "would_pass": passed_s,
                                                "misses": misses_s}
    meta["orders"] = _order_table(fe.theta_in[wf], fe.te[wf], rom.theta_in[wr], rom.te[wr], z1)
    return SpeedComparison(rpm, fe, rom.t, rom.theta_in, rom.te, meta, metrics, passed, misses, wf, wr, gates)


def _order_table(th_fe, te_fe, th_rom, te_rom, z1: int) -> dict:
    """Amplitudes [um] and phases [deg] of mesh orders 1..PERIODIC_ORDERS of FE and ROM: where the
    periodic DTE RMS comes from."""
    fe = te_metrics(th_fe, te_fe, z1, orders=PERIODIC_ORDERS)
    rom = te_metrics(th_rom, te_rom, z1, orders=PERIODIC_ORDERS)
    keys = range(1, PERIODIC_ORDERS + 1)
    return {"order": list(keys),
            "fe_amplitude_um": [fe[f"gmf{m}_amplitude_um"] for m in keys],
            "rom_amplitude_um": [rom[f"gmf{m}_amplitude_um"] for m in keys],
            "fe_phase_deg": [fe[f"gmf{m}_phase_deg"] for m in keys],
            "rom_phase_deg": [rom[f"gmf{m}_phase_deg"] for m in keys]}


@dataclass(frozen=True, eq=False)
class ValidationReport:
    """ROM vs explicit FE at several speeds (``speeds``: list of :class:`SpeedComparison`)."""

    config: str
    speeds: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"config": self.config, "speeds": [s.to_dict() for s in self.speeds],
                "passed": all(s.passed for s in self.speeds)}

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=2, default=float) + "\n")
        return path

    def plot(self):
        """TE vs input angle (steady window, in mesh periods) and the TE spectra over mesh order."""
        from gearrom.plotting import subplots

        n = len(self.speeds)
        fig, axes = subplots(n, 2, figsize=(11, 3.2 * n), squeeze=False)
        for row, s in zip(axes, self.speeds):
            rom_label = {"exudyn": "exudyn ROM", "exudyn-bodies": "exudyn ROM, flexible bodies"}.get(
                s.rom_meta.get("rom_model"), "pair ROM")
            z1 = s.rom_meta.get("z1") or int(round(2 * math.pi * s.rom_meta["mesh_frequency_Hz"] / (s.rpm_in * 2 * math.pi / 60)))
            for lab, th, te, w, st in (("explicit FE", s.fe.theta_in, s.fe.te, s.fe_window, "k-"),
                                       (rom_label, s.rom_theta_in, s.rom_te, s.rom_window, "C1--")):
                x = th[w] * z1 / (2 * math.pi)
                row[0].plot(x, te[w] * 1e6, st, lw=1, label=lab)
                d = te[w] - te[w].mean()
                spec = spectrum(d, 1.0).amplitude * 1e6
                order = np.arange(spec.size) / (x[-1] - x[0] + (x[1] - x[0]))
                row[1].plot(order, spec, st, lw=1, label=lab, marker="." if lab == "explicit FE" else "o", ms=3)
            row[0].set(xlabel="input angle [mesh periods]", ylabel="TE [um]",
                       title=f"{s.rpm_in:g} rpm ({'pass' if s.passed else 'FAIL'})")
            row[1].set(xlabel="mesh order", ylabel="DTE amplitude [um]", xlim=(0, 6))
            row[0].legend(fontsize=8)
            row[1].legend(fontsize=8)
        fig.suptitle(f"{self.config}: ROM vs explicit FE")
        fig.tight_layout()
        return fig


#: mesh tables of :func:`validate`: the quasi-static LTCA (default) or the LTCA at the explicit FE's static compliance
TABLES = ("ltca", "explicit_scaled")
#: reduced models of :func:`validate`: the 1-DOF pair ROM (default) or the same system as an exudyn Drivetrain
ROM_MODELS = ("pair", "exudyn", "exudyn-bodies")


def validate(config: str, rpms, fe_dir: str | Path | None = None, fresh: bool = False,
             excitation_source: str = "fe", damping_ratio: float | None = None, facets: bool = True,
             table: str = "ltca", rom_model: str | None = None, fe_integration: str | None = None) -> ValidationReport:
    """Compare the pair ROM with the explicit FE of ``config`` at each input speed in ``rpms``.

    Parameters
    ----------
    config : str
        Config name or path.
    rpms : sequence of float
        Input speeds, rev/min.
    fe_dir : path, optional
        Folder of the stored FE records (default: the repository's validation/).
    fresh : bool
        Run a coarse explicit FE now instead of loading the stored records (spur only).
    excitation_source : str
        Source of the LTCA table (:func:`gearrom.validation.pair_rom.mesh_excitation`).
    damping_ratio : float, optional
        Mesh damping ratio of the ROM. Default: the FE model's own dissipation, i.e. 0 for records
        without any (fully integrated elements, no mass damping, frictionless: :func:`fe_damping_ratio`)
        and 0.01 for the one-point records (their hourglass viscosity dissipates).
    facets : bool
        Add the kinematic TE of the FE's faceted outlines to the ROM (same discretised gears). Records whose
        outline nodes lie on the generated profile (``outline_on_profile``) get none: their chords are
        within the profile's sag, which the tolerances do not resolve.
    table : str
        ``"ltca"`` (default): the quasi-static LTCA table (P2, the config's ``[fe]`` mesh; for the
        loaded-start references its flank grid refined to
        :data:`gearrom.validation.pair_rom.REFERENCE_FLANK_SIZE`, the grid of the static gate). ``"explicit_scaled"``: the
        LTCA table with its stiffness scaled to the static compliance of the explicit FE's own slow run
        ``spur_60rpm`` (Q4, 0.15 mm outline, penalty contact; scale 0.932, from static data only),
        :func:`gearrom.validation.explicit_table.explicit_scaled_excitation`; spur pairs, stored records,
        facets and the LTCA table only. Its provenance is written to each speed's ``rom.table``.
    rom_model : str, optional
        ``"pair"`` (1-DOF RK4, the FE's torque ramp), ``"exudyn"`` (the project's drivetrain ROM of the
        same system: :mod:`gearrom.validation.pair_exudyn`) or ``"exudyn-bodies"`` (the same with flexible gear
        bodies from the FE's meshes, :func:`gear_bodies`), see :func:`validate_speed`. Default: "exudyn"
        for loaded-start records (both start loaded at speed), "pair" for the others.
    fe_integration : str, optional
        Stored records of the explicit FE with ``"full"`` (fully integrated Q4, no hourglass energy:
        ``spur_<rpm>rpm_full.*``) or ``"reduced"`` elements (one-point + hourglass control:
        ``spur_<rpm>rpm.*``) or the ``"loaded"`` references (``spur_<rpm>rpm_loaded.*``: loaded static start,
        calibrated damping). Default: per speed the first of "loaded", "full", "reduced" that is stored
        (each speed's ``fe.record`` in the report says which); the same for helical records.
    """
    if fe_integration is not None and fe_integration not in FE_INTEGRATIONS:
        raise ConfigError(f"fe_integration must be one of {FE_INTEGRATIONS}, got {fe_integration!r}")
    if rom_model is not None and rom_model not in ROM_MODELS:
        raise ConfigError(f"rom_model must be one of {ROM_MODELS}, got {rom_model!r}")
    if table not in TABLES:
        raise ConfigError(f"table must be one of {TABLES}, got {table!r}")
    from gearrom.config import as_config

    cfg = as_config(config, check=True, quiet=False)
    pair = cfg.pair
    helical = pair.is_helical
    if helical and fresh:
        raise ConfigError(f"{cfg.name}: --fresh runs the 2D spur FE only; the helical 3D explicit FE takes about half "
                          "an hour per speed (validation/run_explicit_helical.py RPM): use the stored records")
    prefix = record_prefix(pair, cfg.name)
    facets = facets and not helical
    if table == "explicit_scaled" and (helical or fresh or not facets or excitation_source != "fe"):
        raise ConfigError("table='explicit_scaled' comes from the stored 2D spur explicit FE's slow run: it needs a spur "
                          "pair, stored records (not --fresh: other mesh), the outline facets (the scale is of the "
                          "elastic part) and the LTCA table (excitation 'fe')")
    if table == "explicit_scaled":
        if fe_integration in ("full", "loaded"):
            raise ConfigError("table='explicit_scaled' is the static compliance of the one-point (reduced) explicit "
                              "FE's slow run: compare it with the one-point records (fe_integration='reduced')")
        fe_integration = "reduced"
    fe_dir = Path(fe_dir) if fe_dir is not None else DEFAULT_FE_DIR
    records = {}
    for rpm in rpms:
        if not rpm > 0:
            raise ConfigError(f"--rpm values must be > 0, got {rpm}")
        records[rpm] = (fresh_fe_record(pair, rpm, cfg.operating.torque_out) if fresh
                        else load_fe_record(fe_dir, rpm, prefix, fe_integration or _preferred_integration(fe_dir, rpm, prefix)))
        if not fresh:
            check_record_pair(records[rpm], pair, f"{cfg.name} at {rpm:g} rpm ({prefix} record in {fe_dir})")
    from gearrom.fe.mesh2d import settings_from_section

    fe_settings, _ = settings_from_section(cfg.section("fe"), str(cfg.source or cfg.name))
    speeds = []
    cache: dict = {}
    cache_bodies: dict = {}
    for rpm, fe in records.items():
        torque = float(fe.meta["torque_out_Nm"])
        loaded = fe.meta.get("start") == "loaded"       # the references: the sweep's load-dependent table
        tkey = (torque, loaded)
        if tkey not in cache:
            cache[tkey] = mesh_excitation(pair, torque, excitation_source, config_name=cfg.name, torque_map=loaded,
                                          settings=reference_settings(pair, fe_settings) if loaded else None,
                                          n_slices=REFERENCE_SLICES if loaded else None) + (None,)
            if table == "explicit_scaled":
                cache[tkey] = _explicit_scaled(pair, cache[tkey][0], fe_dir, torque)
        ex, ex_label, provenance = cache[tkey]
        if provenance is not None:
            _check_same_mesh(provenance, fe)
        key = (fe.meta.get("outline_size_mm", 0.15), fe.meta.get("body_size_mm", 1.5),   # helical: transverse mesh
               fe.meta.get("grading_mm"))
        on_profile = bool(fe.meta.get("outline_on_profile", False))
        key = key + (on_profile,)
        if key not in cache:
            cache[key] = output_inertia(pair, key[0] * 1e-3, key[1] * 1e-3, None if key[2] is None else key[2] * 1e-3,
                                        project=on_profile and not helical)
        j2, j_label = cache[key]
        if "inertia_out_kgm2" in fe.meta:           # the run's own (mass scaling included)
            j2, j_label = float(fe.meta["inertia_out_kgm2"]), "sum m r^2 of the FE output gear's nodal masses (the run's)"
        kin = None
        if facets and not on_profile:
            kin = facet_kinematic_te(pair, ex, torque, key[0] * 1e-3, key[1] * 1e-3,
                                     rpm * 2 * math.pi / 60 * float(fe.t[-1]))
        zeta = fe_damping_ratio(fe) if damping_ratio is None else float(damping_ratio)
        model = rom_model or ("exudyn" if fe.meta.get("start") == "loaded" else "pair")
        bodies = None
        if model == "exudyn-bodies":
            if key not in cache_bodies:
                cache_bodies[key] = gear_bodies(pair, key[0] * 1e-3, key[1] * 1e-3,
                                                None if key[2] is None else key[2] * 1e-3, project=on_profile)
            bodies = cache_bodies[key]
            if "inertia_in_kgm2" in fe.meta:        # the run's own input gear (mass scaling included)
                bodies = (bodies[0].with_inertia(float(fe.meta["inertia_in_kgm2"])), bodies[1])
        s = validate_speed(pair, rpm, fe, ex, ex_label, j2, j_label, zeta, kinematic=kin,
                           table_provenance=provenance, rom_model=model, bodies=bodies)
        s.rom_meta["z1"] = pair.z[0]
        speeds.append(s)
    return ValidationReport(cfg.name, speeds)


def _preferred_integration(fe_dir: Path, rpm: float, prefix: str = "spur") -> str:
    """The first kind of :data:`FE_INTEGRATIONS` stored for ``rpm``. When none is: "loaded" for a pair with a
    record prefix of its own (micro-geometry: only references from the loaded start are made for it), so that
    the error names the record to make, else "reduced"."""
    for kind in FE_INTEGRATIONS:
        if record_stem(fe_dir, rpm, prefix, kind).with_suffix(".npz").is_file():
            return kind
    return "loaded" if "-" in prefix else "reduced"


def fe_damping_ratio(fe: FERecord) -> float:
    """The ROM mesh damping ratio that describes the FE record's system: the record's calibrated ratio at
    the mesh mode (``zeta_target``, loaded-start records), 0 when the FE model dissipates nothing (fully
    integrated elements, so no hourglass viscosity; no mass damping; mu = 0), else 0.01."""
    if "zeta_target" in fe.meta:
        return float(fe.meta["zeta_target"])
    undamped = (fe.meta.get("integration") == "full" and not fe.meta.get("mass_damping_per_s", 0.0)
                and not fe.meta.get("mu", 0.0))
    return 0.0 if undamped else 0.01


def _explicit_scaled(pair, reference, fe_dir: Path, torque: float):
    """(table, label, provenance) of ``table="explicit_scaled"`` from the stored slow run at ``torque``."""
    from gearrom.validation.explicit_table import explicit_scaled_excitation

    table, label, prov = explicit_scaled_excitation(pair, reference, fe_dir)
    if abs(prov["slow_run_torque_Nm"] - torque) > 1e-9 * torque:
        raise ConfigError(f"explicit_scaled: the slow run is at {prov['slow_run_torque_Nm']:g} N m, the record at "
                          f"{torque:g} N m")
    return table, label, prov


def _check_same_mesh(provenance: dict, fe: FERecord) -> None:
    """ConfigError unless the slow run behind an ``explicit_scaled`` table used the record's mesh sizes."""
    for key in ("outline_size_mm", "body_size_mm"):
        a, b = provenance["fe_meta"].get(key), fe.meta.get(key)
        if a is None or b is None or abs(float(a) - float(b)) > 1e-9:
            raise ConfigError(f"explicit_scaled: the slow run's {key} ({a}) differs from the record's ({b}): "
                              "not the same discretised gears")
