"""The simulator interface the diagnosis talks to, and the adapter to the exudyn ROM.

The diagnosis needs one thing from a dynamic model: shaft angle histories at the encoders for a
run condition, with optional *model changes* (the effects of the library). :class:`Simulator` is
that contract. Two implementations:

* :class:`gearrom.calibrate.torsional.TorsionalRig`: a small torsional drivetrain (numba RK4), always
  available, fast, with assumed rig values; it can re-tune rig parameters (``torsional_mode``).
* :class:`RomSimulator`: adapter to the exudyn ROM ``gearrom.rom.simulate_run``: the
  project's drivetrain model built from the configuration's ``[rig]`` description.

:func:`default_simulator` picks the ROM for configurations that describe a rig, else the torsional
rig model. Any object with ``name``, ``simulate``, ``tunable`` and ``modes_hz`` can be passed to
:func:`gearrom.calibrate.diagnose` instead (e.g. a wrapper around another simulator).

The run conditions, model changes and histories they exchange are in :mod:`gearrom.calibrate.runs`.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from gearrom.calibrate.microfe import with_micro
from gearrom.calibrate.torsional import TorsionalRig
from gearrom.calibrate.runs import ModelChanges, RunConditions, SimHistory, Simulator
from gearrom.excitation.slices import MicroMods
from gearrom.errors import CalibrationError

log = logging.getLogger(__name__)


def periodic_lookup(table: np.ndarray | None):
    """A callable ``f(theta)`` interpolating a one-revolution table periodically (zero if None)."""
    if table is None:
        return lambda th: 0.0 * np.asarray(th, float)
    tab = np.asarray(table, float)
    n = tab.size
    grid = np.arange(n + 1) * (2 * math.pi / n)
    ext = np.append(tab, tab[0])
    return lambda th: np.interp(np.mod(th, 2 * math.pi), grid, ext)


@dataclass(frozen=True)
class Tunable:
    """A rig parameter the ROM adapter can scale.

    Attributes
    ----------
    keys : tuple of str
        Config keys (dotted, :func:`gearrom.rom.rig_parameters`) scaled together; empty for a parameter
        without a config key.
    description : str
    lo, hi : float
        Range of the scale the diagnosis searches.
    step : float
        Ratio between neighbouring scales of the search ladder.
    interacts : bool
        The diagnosis judges each scale with the accepted effects refitted on the re-tuned rig (a
        profile): for a parameter that changes how a kinematic error reaches the encoders over its
        search range.
    linear : bool
        The profile takes the re-tuned rig's response to a kinematic error from the simulated nominal
        response times the change of the linearized drivetrain's response (:meth:`RomSimulator.response_ratio`)
        instead of re-simulating every scale, and the change of the nominal model's GMF lines from the
        same ratio at their frequencies: for a parameter whose change the linearized drivetrain holds
        (an inertia, a coupling, a support stiffness). The accepted kinematic errors are refitted on the
        re-tuned responses. The verification re-simulates the chosen scale.
    """

    keys: tuple[str, ...]
    description: str
    lo: float = 0.4
    hi: float = 2.5
    step: float = 1.25
    interacts: bool = False
    linear: bool = False


#: Rig parameters the ROM adapter can scale. The bearing supports are an assumption of most rig configs
#: (catalogue stiffnesses, housing compliance unknown) and matter through the helical mesh's axial and
#: tilting forces, so their scale is searched over three decades.
ROM_TUNABLE = {
    "k_clutch": Tunable(("rig.clutch.stiffness_Nm_per_rad",), "clutch/coupling torsional stiffness"),
    "J_load": Tunable(("rig.load.inertia_kg_m2",), "load-side inertia", interacts=True, linear=True),
    "J_motor": Tunable(("rig.motor.inertia_kg_m2",), "motor rotor inertia", interacts=True, linear=True),
    "k_support": Tunable(("rig.bearings.ball_radial_N_per_um", "rig.bearings.ball_axial_N_per_um",
                          "rig.bearings.needle_radial_N_per_um"),
                         "bearing support stiffness (ball radial and axial, needle radial, scaled together)",
                         lo=0.1, hi=100.0, step=10 ** 0.5, interacts=True, linear=True),
    "mesh_stiffness": Tunable((), "mesh stiffness level (scales the excitation table)"),
}


def _scale_key(rig_scale) -> tuple:
    """A rig scale ``((name, factor), ...)`` as a hashable cache key (factors rounded to 1e-9)."""
    return tuple((str(n), round(float(v), 9)) for n, v in rig_scale)


class RomSimulator:
    """Adapter to the exudyn ROM (:func:`gearrom.rom.simulate_run`).

    Mapping of :class:`ModelChanges`:

    * kinematic errors -> ``Effects(extra=(ExtraTE(fn),))`` with ``fn(theta1, theta2)`` evaluated in the
      record's angle reference (the ROM passes absolute drive-sense angles);
    * micro-geometry -> the ROM's nominal table plus the change the micro-geometry model (default: the
      quasi-static FE tables, :class:`~gearrom.calibrate.microfe.FEMicroModel`) predicts between the
      nominal and the modified flanks (:func:`~gearrom.calibrate.microfe.with_micro`);
    * mesh phase -> ``theta0`` chosen so that the input gear stands at ``mesh_phase_rad`` when the
      record starts (the ROM's mesh table is evaluated at the absolute input angle);
    * load ripple -> ``Effects(load_ripple=(LoadRipple(order, amplitude, phase),))`` (N m, output order;
      the ROM writes ``sin``, the phase is shifted by 90 deg to keep this module's cosine convention).

    * rig scaling -> :func:`gearrom.rom.with_overrides` of the config's rig values (``ROM_TUNABLE``);
      ``mesh_stiffness`` scales the stiffness of the configured mesh excitation table.
    """

    name = "gearrom.rom (exudyn)"

    def __init__(self, config, micro_model=None, sample_rate_hz: float = 50e3, settle_s: float = 0.02):
        import gearrom.rom as rom

        from gearrom.calibrate.microfe import FEMicroModel

        self._rom = rom
        self.config = config
        self.micro_model = micro_model or FEMicroModel()
        self.sample_rate_hz = float(sample_rate_hz)
        self.settle_s = round(settle_s * sample_rate_hz) / sample_rate_hz
        self._models: dict = {}
        self._modes: dict = {}
        self._linear: dict = {}
        from gearrom.config import as_config

        self.pair = as_config(config).pair
        self.micro = MicroMods.from_pair(self.pair)

    def tunable(self) -> dict[str, str]:
        return {k: v.description for k, v in ROM_TUNABLE.items()}

    def search_range(self, name: str) -> tuple[float, float, float]:
        """(lowest, highest scale, ladder ratio) the diagnosis searches for rig parameter ``name``."""
        t = ROM_TUNABLE[name]
        return t.lo, t.hi, t.step

    def interacts(self, name: str) -> bool:
        """Whether rig parameter ``name`` is fitted together with the accepted kinematic errors."""
        return ROM_TUNABLE[name].interacts

    def linear_interaction(self, name: str) -> bool:
        """Whether the profile of rig parameter ``name`` may use :meth:`response_ratio`."""
        return ROM_TUNABLE[name].linear

    def response_ratio(self, rpm_in: float, torque_out_Nm: float, rig_scale: tuple, freqs_hz) -> np.ndarray:
        """Complex ratio (3, n) of the re-tuned to the nominal rig's linear response to a kinematic error at
        the mesh, for ``te``, ``u_in`` and ``u_out`` (the encoder angles times the base radii) at ``freqs_hz``.

        From the linearized drivetrain at the mean mesh stiffness (:func:`gearrom.rom.frf.state_matrices`,
        its input the static TE; a kinematic error enters the same way), in modal form. Where the nominal
        response of a channel is below 1e-3 of its largest, the ratio is 1 (nothing to scale).
        """
        s = 2j * math.pi * np.asarray(freqs_hz, float)
        nom, new = (self._modal_io(rpm_in, torque_out_Nm, sc) for sc in ((), tuple(rig_scale)))
        resp = [cv @ (w[:, None] / (s[None, :] - lam[:, None])) for cv, w, lam in (nom, new)]
        big = np.abs(resp[0]) >= 1e-3 * np.abs(resp[0]).max(axis=1, keepdims=True)
        return np.where(big, resp[1] / np.where(big, resp[0], 1.0), 1.0)

    def _modal_io(self, rpm_in: float, torque: float, rig_scale: tuple):
        """``(C V, V^-1 B, eigenvalues)`` of the linearized drivetrain from the static TE to te, u_in, u_out."""
        key = (round(rpm_in, 6), round(torque, 6), _scale_key(rig_scale))
        if key not in self._linear:
            from gearrom.rom.components import RZ
            from gearrom.rom.frf import state_matrices

            model = self._model(None, torque, rig_scale)
            A, B, C, names = state_matrices(model, rpm_in, torque)
            rows = [C[names.index("dte_sensor")]]
            for shaft, rb in (("in", self.pair.rb[0]), ("out", self.pair.rb[1])):
                enc = [e for e in model.encoders if e.side == "sensor" and e.shaft == shaft]
                c = np.zeros(A.shape[0])
                c[model.index(enc[0].station, RZ)] = rb
                rows.append(c)
            from threadpoolctl import threadpool_limits

            with threadpool_limits(limits=1, user_api="blas"):  # a small dense problem: threads only stall
                lam, V = np.linalg.eig(A)
                self._linear[key] = (np.vstack(rows) @ V, np.linalg.solve(V, B[:, 0]), lam)
        return self._linear[key]

    def table_stiffness(self, torque_out_Nm: float, rig_scale=()) -> float:
        """Mean mesh stiffness [N/m] of the table the ROM runs at ``torque_out_Nm`` (its secant at that
        torque, ``mesh_stiffness`` scale applied): the level the ROM scales the slices of its pitch
        deviations to, and so the level of the diagnosis' tooth model."""
        model = self._model(None, torque_out_Nm, tuple(rig_scale))
        return float(np.mean(model.excitation.sampled(float(torque_out_Nm), 256)[1]))

    def modes_hz(self, rig_scale=()) -> list[tuple[float, float]]:
        key = _scale_key(rig_scale)
        if key not in self._modes:
            try:
                res = self._rom.modal_analysis(self._model(None, 120.0, key))
                self._modes[key] = [(float(f), float(z)) for f, z in zip(res.freqs, res.damping)]
            except Exception:  # noqa: BLE001  (modal data are informative only)
                self._modes[key] = []
        return list(self._modes[key])

    def _model(self, micro: MicroMods | None, torque: float, rig_scale: tuple = ()):
        key = (micro, round(torque, 6), _scale_key(rig_scale))
        if key not in self._models:
            import dataclasses

            from gearrom.rom.rig import load_excitation, rom_section

            scale = dict(key[2])
            unknown = sorted(set(scale) - set(ROM_TUNABLE))
            if unknown:
                raise CalibrationError(f"RomSimulator: rig parameter(s) {unknown} not tunable; choose from {sorted(ROM_TUNABLE)}")
            cfg = self.config
            if any(ROM_TUNABLE[n].keys for n in scale):
                params = self._rom.rig_parameters(self.config)
                cfg = self._rom.with_overrides(self.config, {
                    k: float(params[k]) * v for n, v in scale.items() for k in ROM_TUNABLE[n].keys})
            ex = None
            if (micro is not None and micro != self.micro) or "mesh_stiffness" in scale:
                loaded = self._rom_cfg()
                ex = load_excitation(loaded, rom_section(loaded), torque)  # the ROM's own nominal table
            if micro is not None and micro != self.micro:
                ex = with_micro(ex, self.micro_model, self.pair, torque, self.micro, micro)
            if "mesh_stiffness" in scale:
                ex = dataclasses.replace(ex, k=ex.k * scale["mesh_stiffness"])
            self._models[key] = self._rom.build_rig(cfg, torque, excitation=ex)
        return self._models[key]

    def _rom_cfg(self):
        from gearrom.config import as_config

        return as_config(self.config)

    def simulate(self, run: RunConditions, changes: ModelChanges | None = None) -> SimHistory:
        from gearrom.rom import Effects, ExtraTE, LoadRipple

        ch = changes or ModelChanges()
        if ch.micro is not None and self.micro_model is None:
            raise CalibrationError("RomSimulator: no micro-geometry model to build a mesh table from")
        z1, z2 = self.pair.z
        omega = run.rpm_in * math.pi / 30.0
        psi = float(ch.mesh_phase_rad)
        theta0 = psi - omega * self.settle_s  # input gear at psi when the record starts
        extra, ripple = (), ()
        if ch.kinematic_in is not None or ch.kinematic_out is not None:
            f1, f2 = periodic_lookup(ch.kinematic_in), periodic_lookup(ch.kinematic_out)
            a2 = psi * z1 / z2
            extra = (ExtraTE(lambda th1, th2: f1(th1 - psi) + f2(th2 - a2), label="calibrate"),)
        if ch.load_ripple is not None:
            amp, order, phase = ch.load_ripple
            ripple = (LoadRipple(order=float(order), amplitude=float(amp) * run.torque_out_Nm,
                                 phase=float(phase) + math.pi / 2),)
        model = self._model(ch.micro, run.torque_out_Nm, tuple(ch.rig_scale))
        own = Effects.from_pair(self.pair)  # runout and pitch deviations the config declares stay in the model
        res = self._rom.simulate_run(model, run.rpm_in, run.torque_out_Nm, duration_s=run.duration_s,
                                     effects=Effects(runout=own.runout, pitch=own.pitch, extra=extra,
                                                     load_ripple=ripple),
                                     sample_rate_hz=self.sample_rate_hz, settle_s=self.settle_s, theta0=theta0)
        th1 = np.asarray(res.angle("in", "sensor"), float)
        th2 = np.asarray(res.angle("out", "sensor"), float)
        t = np.asarray(res.time, float)
        return SimHistory(t - t[0], th1 - psi, th2 - psi * z1 / z2, info={"simulator": self.name})


def default_simulator(config, prefer: str = "auto") -> Simulator:
    """The simulator the diagnosis uses for ``config``.

    Parameters
    ----------
    config : str or Path
        Gear configuration name or file.
    prefer : {"auto", "rom", "torsional"}
        ``"rom"``: the exudyn ROM (:class:`RomSimulator`); ``"torsional"``: the small torsional rig
        model; ``"auto"``: the ROM when the configuration describes a rig (a ``[rig]`` section, as
        ``thesis-rig``), since it is then the user's own drivetrain; otherwise the torsional rig model
        (fast, with assumed rig values).
    """
    if prefer == "auto":
        from gearrom.config import as_config

        try:
            has_rig = bool(as_config(config).section("rig"))
        except Exception:  # noqa: BLE001  (a bad config is reported by the simulator that loads it)
            has_rig = False
        if has_rig:
            try:
                return RomSimulator(config)
            except ImportError:
                log.warning("config %s describes a rig but the exudyn ROM is not importable; using the "
                            "torsional rig model", config)
    if prefer == "rom":
        try:
            return RomSimulator(config)
        except ImportError as exc:
            raise CalibrationError(f"the exudyn ROM is not available: {exc}") from exc
    if prefer not in ("auto", "torsional"):
        raise CalibrationError(f"simulator {prefer!r}: choose 'auto', 'rom' or 'torsional'")
    return TorsionalRig.from_config(config)
