"""Modal analysis and Campbell diagram from the assembled matrices (scipy).

At the mean mesh stiffness the model is ``M x'' + (D + Omega G) x' + (K + k w w^T) x = 0``. Natural
frequencies come from the undamped gyroscopic problem (first-order form, ``D = 0``), damping ratios
from the damped one. The mesh strain-energy share of a mode is ``k |w . x|^2 / (x^H K_tot x)``.
The rigid rotation (zero frequency, speed-controlled motor) is dropped.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.errors import ModelError
from gearrom.rom.model import Drivetrain


@dataclass(eq=False)
class ModalResult:
    """Modes at one speed: frequencies [Hz], damping ratios [-], shapes (n_dof, n_modes), mesh energy share."""

    rpm_in: float
    freqs: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray
    mesh_share: np.ndarray
    labels: list[str]

    def dominant(self, i: int, n: int = 3) -> list[str]:
        """Labels of the ``n`` DOFs with the largest amplitude in mode ``i``."""
        a = np.abs(self.shapes[:, i])
        return [self.labels[j] for j in np.argsort(a)[::-1][:n]]

    def save(self, path: str | Path) -> Path:
        """Write the modes as JSON (frequencies, damping, mesh share, real parts of the shapes)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        d = {"rpm_in": self.rpm_in, "modes": self.table(), "labels": self.labels,
             "shapes_real": np.real(self.shapes).tolist(), "shapes_imag": np.imag(self.shapes).tolist()}
        path.write_text(json.dumps(d, indent=1) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> "ModalResult":
        d = json.loads(Path(path).read_text())
        if "modes" not in d or "shapes_real" not in d:
            raise ModelError(f"{path}: not a gearrom modes file")
        m = d["modes"]
        return cls(d["rpm_in"], np.array([x["frequency_Hz"] for x in m]),
                   np.array([np.nan if x["damping_ratio"] is None else x["damping_ratio"] for x in m]),
                   np.array(d["shapes_real"]) + 1j * np.array(d["shapes_imag"]),
                   np.array([x["mesh_energy_share"] for x in m]), d["labels"])

    def plot(self):
        """Natural frequencies with their mesh strain-energy share."""
        from gearrom.plotting import subplots

        fig, ax = subplots(figsize=(8, 4))
        ax.bar(np.arange(1, len(self.freqs) + 1), self.mesh_share, color="C0")
        for i, f in enumerate(self.freqs):
            ax.text(i + 1, self.mesh_share[i] + 0.01, f"{f:.0f}", rotation=90, ha="center", va="bottom", fontsize=7)
        ax.set_xlabel("mode")
        ax.set_ylabel("mesh strain-energy share [-] (labels: Hz)")
        ax.set_ylim(0, 1.15)
        ax.set_title(f"modes at {self.rpm_in:.0f} rpm", fontsize=9)
        fig.tight_layout()
        return fig

    def table(self) -> list[dict]:
        return [{"mode": i + 1, "frequency_Hz": float(f), "damping_ratio": None if np.isnan(z) else float(z),
                 "mesh_energy_share": float(s),
                 "dominant_dofs": self.dominant(i)} for i, (f, z, s) in enumerate(zip(self.freqs, self.damping, self.mesh_share))]


def _first_order_eigs(M, K, C):
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    lam, vec = np.linalg.eig(A)
    sel = lam.imag > 1e-6
    lam, vec = lam[sel], vec[:n, sel]
    order = np.argsort(np.abs(lam))
    return lam[order], vec[:, order]


def modal_analysis(model: Drivetrain, rpm_in: float = 0.0, torque_out: float | None = None,
                   fmax: float | None = None, damping: bool = True) -> ModalResult:
    """Modes of ``model`` at ``rpm_in`` with the mean mesh stiffness at ``torque_out`` [N m].

    Parameters
    ----------
    fmax : float, optional
        Keep modes up to this frequency [Hz] (default all).
    damping : bool
        Also solve the damped problem for the damping ratios (else NaN).
    """
    torque = float(model.metadata.get("torque_out_Nm", 120.0) if torque_out is None else torque_out)
    M, K, D = model.linear(rpm_in, torque)
    _, _, _, G = model.structure
    omega = rpm_in * 2 * math.pi / 60
    lam, vec = _first_order_eigs(M, K, omega * G)
    freqs = np.abs(lam) / (2 * math.pi)
    rigid = freqs < 1.0
    lam, vec, freqs = lam[~rigid], vec[:, ~rigid], freqs[~rigid]
    if fmax is not None:
        keep = freqs <= fmax
        lam, vec, freqs = lam[keep], vec[:, keep], freqs[keep]
    k = model.mesh_stiffness(torque)
    strain = np.real(np.einsum("im,ij,jm->m", vec.conj(), K, vec))
    share = k * np.abs(model.w @ vec) ** 2 / np.maximum(strain, 1e-300)
    if not damping:
        zeta = np.full(freqs.shape, np.nan)
        shapes = vec / vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
        return ModalResult(float(rpm_in), freqs, zeta, shapes, np.clip(share, 0.0, 1.0), model.dof_labels())
    # damping ratios from the damped problem, matched by frequency
    lam_d, _ = _first_order_eigs(M, K, D)
    fd = np.abs(lam_d) / (2 * math.pi)
    zeta = np.array([-lam_d[np.argmin(abs(fd - f))].real / abs(lam_d[np.argmin(abs(fd - f))]) for f in freqs])
    shapes = vec / vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
    return ModalResult(float(rpm_in), freqs, zeta, shapes, np.clip(share, 0.0, 1.0), model.dof_labels())


@dataclass(eq=False)
class CampbellResult:
    """Natural frequencies vs speed, excitation orders and crossings.

    Attributes
    ----------
    rpm : ndarray (n_rpm,)
        Input speeds [rpm].
    freqs, mesh_share : ndarray (n_rpm, n_modes)
        Frequencies [Hz] (sorted at each speed) and mesh strain-energy shares [-].
    orders : dict of str -> float
        Excitation frequency per input rpm/60: ``GMF1..3`` (m z1), ``input shaft`` (1), ``output shaft`` (z1/z2).
    crossings : list of dict
        ``{"mode", "order", "rpm_in", "frequency_Hz", "mesh_energy_share"}``.
    """

    config: str
    rpm: np.ndarray
    freqs: np.ndarray
    mesh_share: np.ndarray
    orders: dict[str, float]
    crossings: list[dict] = field(default_factory=list)

    def to_json(self) -> dict:
        return {"config": self.config, "rpm_in": self.rpm.tolist(),
                "modes_Hz_at_lowest_speed": self.freqs[0].tolist(),
                "mesh_energy_share_at_lowest_speed": self.mesh_share[0].tolist(),
                "orders": self.orders, "crossings": self.crossings}

    def save(self, path: str | Path) -> Path:
        """Write JSON (all arrays included)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        d = self.to_json()
        d["freqs_Hz"] = self.freqs.tolist()
        d["mesh_share"] = self.mesh_share.tolist()
        path.write_text(json.dumps(d, indent=1) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> "CampbellResult":
        d = json.loads(Path(path).read_text())
        if "freqs_Hz" not in d:
            raise ModelError(f"{path}: not a gearrom Campbell file (no 'freqs_Hz')")
        return cls(d["config"], np.array(d["rpm_in"]), np.array(d["freqs_Hz"]), np.array(d["mesh_share"]),
                   d["orders"], d["crossings"])

    def plot(self, fmax: float | None = None, min_share: float = 0.01):
        """Campbell diagram: mode frequencies [Hz] over input speed [rpm], GMF and shaft-order lines.

        The modes that the mesh excites (mesh strain-energy share of at least ``min_share`` at some
        speed) are drawn thick, coloured by that share and named; the others thin and grey. Crossings
        of the order lines with the modes that matter are marked.
        """
        from matplotlib import colormaps
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        from gearrom.plotting import subplots

        gmf = [v for k, v in self.orders.items() if k.startswith("GMF")] or list(self.orders.values())
        fmax = fmax or 1.05 * max(gmf) * self.rpm[-1] / 60
        fig, ax = subplots(figsize=(8, 6))
        cmap = colormaps["plasma_r"]
        top = max(float(self.mesh_share.max()), min_share, 1e-12)
        for j in range(self.freqs.shape[1]):
            if self.freqs[:, j].min() > fmax:
                continue
            share = float(self.mesh_share[:, j].max())
            if share >= min_share:
                ax.plot(self.rpm, self.freqs[:, j], "-", lw=2.5, color=cmap(0.15 + 0.85 * share / top))
                ax.annotate(f"mode {j + 1}", (self.rpm[0], self.freqs[0, j]), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
            else:
                ax.plot(self.rpm, self.freqs[:, j], "-", lw=0.6, color="0.7")
        styles = {"GMF1": ("C0", "--"), "GMF2": ("C1", "--"), "GMF3": ("C2", "--"), "input shaft": ("k", ":"),
                  "output shaft": ("C3", ":")}
        for name, o in self.orders.items():
            col, ls = styles.get(name, ("k", "-."))
            ax.plot(self.rpm, o * self.rpm / 60, ls, color=col, lw=1.2, label=f"{name} (order {o:.4g})")
        for c in self.crossings:
            if c.get("mesh_energy_share", 1.0) >= min_share and c["frequency_Hz"] <= fmax:
                ax.plot(c["rpm_in"], c["frequency_Hz"], "kx", ms=6, mew=1.5)
        fig.colorbar(ScalarMappable(cmap=cmap, norm=Normalize(0, top)), ax=ax,
                     label="mesh strain-energy share [-] (thick lines)")
        ax.set_ylim(0, fmax)
        ax.set_xlim(self.rpm[0], self.rpm[-1])
        ax.set_xlabel("input speed [rpm]")
        ax.set_ylabel("frequency [Hz]")
        ax.set_title(f"{self.config}: Campbell diagram (thick: >= {100 * min_share:g} % mesh energy; "
                     "x: their crossings)", fontsize=9)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=5)
        fig.tight_layout()
        return fig


def campbell(model: Drivetrain, rpm, torque_out: float | None = None, fmax: float | None = None,
             gmf_orders: int = 3, min_share: float = 0.0) -> CampbellResult:
    """Campbell diagram over the speeds ``rpm`` (modes up to ``fmax`` [Hz], default 1.2 x 3rd GMF at top speed)."""
    rpm = np.asarray(rpm, dtype=float)
    z1, z2 = model.pair.z
    orders = {f"GMF{m}": float(m * z1) for m in range(1, gmf_orders + 1)}
    orders.update({"input shaft": 1.0, "output shaft": z1 / z2})
    fmax = fmax or 1.2 * gmf_orders * z1 * rpm.max() / 60
    res = [modal_analysis(model, r, torque_out, fmax=fmax, damping=False) for r in rpm]
    n = min(len(r.freqs) for r in res)
    F = np.array([r.freqs[:n] for r in res])
    S = np.array([r.mesh_share[:n] for r in res])
    crossings = []
    for name, o in orders.items():
        line = o * rpm / 60
        for j in range(n):
            d = F[:, j] - line
            for i in np.nonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)[0]:
                a = d[i] / (d[i] - d[i + 1])
                share = float(S[i, j] + a * (S[i + 1, j] - S[i, j]))
                if share >= min_share:
                    crossings.append({"mode": j + 1, "order": name, "rpm_in": float(rpm[i] + a * (rpm[i + 1] - rpm[i])),
                                      "frequency_Hz": float(F[i, j] + a * (F[i + 1, j] - F[i, j])),
                                      "mesh_energy_share": share})
    crossings.sort(key=lambda c: c["rpm_in"])
    return CampbellResult(model.metadata.get("config", model.name), rpm, F, S, orders, crossings)
