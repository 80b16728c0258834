"""Result of an explicit run: histories at the sample period, final state, run metadata."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError

ENERGY_NAMES = ("kinetic", "internal", "hourglass", "hourglass_viscous", "contact", "friction",
                "damping", "spring", "external_work", "balance_error")

_ARRAYS = ("t", "energies", "theta", "omega", "torque_body", "ref_disp", "probe_ids", "probe_u",
           "probe_v", "u_final", "v_final")


@dataclass(frozen=True, eq=False)
class ExplicitResult:
    """Histories of an explicit FE run (SI units).

    Attributes
    ----------
    t : (nt,) s
    energies : (nt, 10) J, columns :data:`ENERGY_NAMES` (dissipations and external work accumulated
        from t[0]; ``balance_error`` = sum of the first eight - external work - initial total).
    theta, omega : (nt, nr) rad, rad/s, rotation and speed of each rigid reference.
    torque_body : (nt, nr) N m, torque the elastic body exerts on each reference about z.
    ref_disp : (nt, nr, dim) m, translation of each reference.
    probe_ids : (np,) node ids; probe_u, probe_v : (nt, np, dim) m, m/s.
    u_final, v_final : (n, dim) final displacement and velocity (restart / checks).
    meta : dict of run metadata (dt_s, n_steps, n_nodes, n_elements, wall_time_s, ...).
    """

    t: np.ndarray
    energies: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    torque_body: np.ndarray
    ref_disp: np.ndarray
    probe_ids: np.ndarray
    probe_u: np.ndarray
    probe_v: np.ndarray
    u_final: np.ndarray
    v_final: np.ndarray
    meta: dict = field(default_factory=dict)

    def energy(self, name: str) -> np.ndarray:
        """History of one energy column by name (see :data:`ENERGY_NAMES`), J."""
        if name not in ENERGY_NAMES:
            raise ConfigError(f"unknown energy {name!r}; choose from {ENERGY_NAMES}")
        return self.energies[:, ENERGY_NAMES.index(name)]

    @property
    def hourglass_ratio(self) -> float:
        """Largest ratio of the hourglass (stiffness) energy to the internal energy, over the samples
        whose internal energy exceeds 10 % of its maximum (the Abaqus artificial-energy check)."""
        wi = self.energy("internal")
        wh = self.energy("hourglass")
        if wi.size == 0 or wi.max() <= 0:
            return 0.0
        sel = wi > 0.1 * wi.max()
        return float(np.max(wh[sel] / wi[sel]))

    @property
    def hourglass_dissipation_ratio(self) -> float:
        """Viscous hourglass dissipation at the end relative to the energy scale of the run
        (largest of kinetic, internal and |external work|)."""
        scale = max(np.abs(self.energy("kinetic")).max(), np.abs(self.energy("internal")).max(),
                    np.abs(self.energy("external_work")).max(), 1e-300)
        return float(self.energy("hourglass_viscous")[-1] / scale)

    @property
    def energy_error(self) -> float:
        """Largest |balance error| relative to the largest of kinetic, internal, external work.

        The kinetic energy includes the rigid rotation of the gears, which makes this ratio small for
        a running pair; the validation gate (:func:`gearrom.validation.gates.record_gates`) divides by
        the peak strain + hourglass + contact energy instead, the energy the vibration is made of."""
        ref = max(np.abs(self.energy("kinetic")).max(), np.abs(self.energy("internal")).max(),
                  np.abs(self.energy("external_work")).max(), 1e-300)
        return float(np.abs(self.energy("balance_error")).max() / ref)

    def save(self, path: str | Path) -> Path:
        """Write ``<path>.npz`` (arrays) and ``<path>.json`` (metadata); return the npz path."""
        p = Path(path)
        if p.suffix == ".npz":
            p = p.with_suffix("")
        p.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(p.with_suffix(".npz"), **{k: getattr(self, k) for k in _ARRAYS})
        meta = dict(self.meta)
        meta["energy_names"] = list(ENERGY_NAMES)
        meta["hourglass_ratio"] = self.hourglass_ratio
        meta["hourglass_dissipation_ratio"] = self.hourglass_dissipation_ratio
        meta["energy_error"] = self.energy_error
        p.with_suffix(".json").write_text(json.dumps(meta, indent=2, default=float) + "\n")
        return p.with_suffix(".npz")

    @classmethod
    def load(cls, path: str | Path) -> "ExplicitResult":
        """Read a result written by :meth:`save` (give the .npz or the stem)."""
        p = Path(path)
        if p.suffix in (".npz", ".json"):
            p = p.with_suffix("")
        npz, js = p.with_suffix(".npz"), p.with_suffix(".json")
        if not npz.is_file():
            raise ConfigError(f"explicit result file {npz} not found")
        with np.load(npz) as data:
            missing = [k for k in _ARRAYS if k not in data]
            if missing:
                raise ConfigError(f"{npz}: missing arrays {missing}")
            arrays = {k: data[k] for k in _ARRAYS}
        meta = json.loads(js.read_text()) if js.is_file() else {}
        return cls(meta=meta, **arrays)

    def plot(self, path: str | Path | None = None):
        """Energies and reference speeds vs time; return the matplotlib Figure (saved if ``path``)."""
        from gearrom.plotting import subplots

        nr = self.theta.shape[1]
        fig, axes = subplots(2 if nr else 1, 1, figsize=(8, 6 if nr else 3.5), squeeze=False)
        ax = axes[0, 0]
        for k, name in enumerate(ENERGY_NAMES):
            col = self.energies[:, k]
            if np.any(col != 0):
                ax.plot(self.t * 1e3, col, label=name)
        ax.set_xlabel("time (ms)")
        ax.set_ylabel("energy (J)")
        ax.legend(fontsize=7, ncol=2)
        ax.set_title(f"hourglass/internal max {100 * self.hourglass_ratio:.2f} %")
        if nr:
            ax = axes[1, 0]
            for r in range(nr):
                ax.plot(self.t * 1e3, self.omega[:, r] * 30 / np.pi, label=f"reference {r}")
            ax.set_xlabel("time (ms)")
            ax.set_ylabel("speed (rpm)")
            ax.legend(fontsize=7)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=120)
        return fig
