"""Modal reduction of the assembled drivetrain for fast time integration.

The linear part is reduced to the modes below a cutoff frequency computed *with* the mean mesh
stiffness (so the mesh modes are in the basis), augmented by the static responses to a unit mesh
force and to the constant loads (static correction: quasi-static states, in particular the torque
balance ``F = T_out / rb2``, stay exact), re-orthogonalised to mass-normalised Ritz shapes ``Phi``. The modal
coordinates ``eta`` are then re-parametrised, ``y = R eta``, so that the mesh deflection
``delta_t = w . Phi eta`` (and, when needed, the brake angle) are coordinates of their own: the mesh can
then be an exudyn coordinate spring with limit stops (contact loss, back flank) and no Python user
function has to run inside the right-hand side. The structure stiffness ``Phi^T K Phi`` excludes the
mesh (which the connector supplies), the damping includes the gyroscopic terms at the run's speed.

With ``cutoff = inf`` no mode is dropped and the reduced model equals the assembled one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from gearrom.errors import ModelError
from gearrom.rom.model import Drivetrain


@dataclass(frozen=True)
class Reduced:
    """Reduced model in the coordinates ``y`` (see module docstring); all arrays SI."""

    phi: np.ndarray  # (n, r) mass-normalised modes
    freqs: np.ndarray  # (r,) natural frequencies at mean mesh stiffness [Hz]
    T: np.ndarray  # eta = T y
    M: np.ndarray
    K: np.ndarray  # structure only (no mesh)
    D: np.ndarray  # structure + gyroscopic (no mesh)
    F: np.ndarray  # constant loads
    i_delta: int  # index of delta_t in y
    i_brake: int | None  # index of the brake angle in y (when retained)
    w_eta: np.ndarray  # delta = w_eta . eta
    omega_max: float  # spectral radius of the first-order system (largest mesh stiffness) [1/s]

    def to_physical(self, y: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """Physical coordinates (or the given rows of them) from ``y`` (..., r)."""
        P = self.phi if rows is None else self.phi[rows]
        return np.asarray(y) @ (P @ self.T).T


def reduce(model: Drivetrain, rpm_in: float, torque_out: float, cutoff: float | None = None,
           retain_brake: bool = False, min_share: float | None = None) -> Reduced:
    """Reduce ``model`` at ``rpm_in`` and ``torque_out`` (see module docstring).

    Parameters
    ----------
    cutoff : float, optional
        Highest kept natural frequency [Hz] (default ``model.cutoff_frequency``; ``inf`` keeps all).
    retain_brake : bool
        Also make the brake angle a coordinate (for a time-varying brake torque).
    min_share : float, optional
        Also drop modes whose mesh strain-energy share is below this (they are not excited by the mesh;
        0 keeps all modes below the cutoff). Default ``model.min_mesh_share``.
    """
    cutoff = model.cutoff_frequency if cutoff is None else cutoff
    min_share = model.min_mesh_share if min_share is None else min_share
    phi, freqs = model.memo(("modes", float(torque_out), float(cutoff), bool(retain_brake), float(min_share)),
                            lambda: _modes(model, torque_out, cutoff, retain_brake, min_share))
    _, Ks, Ds, G = model.structure
    omega = rpm_in * 2 * math.pi / 60
    Kr = phi.T @ Ks @ phi
    Dr = phi.T @ (Ds + omega * G) @ phi
    Fr = phi.T @ model.loads(torque_out)
    w_eta = phi.T @ model.w
    rows = [w_eta]
    if retain_brake:
        if model.load_station is None:
            raise ModelError("retain_brake needs a model with a load station")
        from gearrom.rom.components import RZ

        rows.append(phi[model.index(model.load_station, RZ)])
    # replace the modal coordinates with the largest pivots by the retained quantities
    _, _, piv = sla.qr(np.array(rows), pivoting=True)
    R = np.eye(phi.shape[1])
    for j, row in enumerate(rows):
        R[piv[j]] = row
    T = np.linalg.inv(R)
    # stability limit of the explicit integrator: spectral radius of the first-order system with the
    # largest mesh stiffness and the mesh damping (stiffness-proportional damping matters here)
    kmax = float(model.excitation.k.max())
    nr = len(w_eta)
    ww = np.outer(w_eta, w_eta)
    A = np.block([[np.zeros((nr, nr)), np.eye(nr)],
                  [-(Kr + kmax * ww), -(Dr + model.mesh_damping(torque_out) * ww)]])
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    return Reduced(
        phi=phi, freqs=freqs, T=T, M=T.T @ T, K=T.T @ Kr @ T, D=T.T @ Dr @ T, F=T.T @ Fr,
        i_delta=int(piv[0]), i_brake=int(piv[1]) if retain_brake else None, w_eta=w_eta,
        omega_max=rho,
    )


def _modes(model: Drivetrain, torque_out: float, cutoff: float, retain_brake: bool,
           min_share: float) -> tuple[np.ndarray, np.ndarray]:
    """Kept modes (with the static correction) and their frequencies [Hz]: the speed-independent
    part of :func:`reduce`."""
    M, Ks, _, _ = model.structure
    kbar = model.mesh_stiffness(torque_out)
    w = model.w
    lam, phi = sla.eigh(Ks + kbar * np.outer(w, w), M)
    lam = np.maximum(lam, 0.0)
    freqs = np.sqrt(lam) / (2 * math.pi)
    keep = freqs <= cutoff
    if min_share > 0:
        # drop modes the mesh cannot excite (mesh strain-energy share below min_share), except the
        # nominal rotation and, when retained, modes that move the brake
        share = np.where(lam > 0, kbar * (w @ phi) ** 2 / np.where(lam > 0, lam, 1.0), 1.0)
        relevant = (share >= min_share) | (freqs < 1e-3 * freqs.max())
        if retain_brake and model.load_station is not None:
            from gearrom.rom.components import RZ

            row = phi[model.index(model.load_station, RZ)]
            relevant |= np.abs(row) >= 1e-3 * np.abs(row).max()
        keep &= relevant
    if keep.sum() < 2:
        raise ModelError(f"cutoff {cutoff:.4g} Hz keeps fewer than 2 modes of model {model.name!r}")
    phi, freqs = phi[:, keep], freqs[keep]
    if not np.all(keep):
        # static correction: add the static responses to a unit mesh force and to the loads, so that
        # every quasi-static state (Sherman-Morrison: span{K^+ F, K^+ w}) is represented exactly
        Kl = Ks + kbar * np.outer(w, w)
        psi = np.linalg.solve(model.gauge(Kl), np.column_stack([w, model.loads(torque_out)]))
        V = np.column_stack([phi, psi])
        lam, Q = sla.eigh(V.T @ Kl @ V, V.T @ M @ V)
        phi = V @ Q
        freqs = np.sqrt(np.maximum(lam, 0.0)) / (2 * math.pi)
    return phi, freqs


def periodic_initial_state(red: Reduced, model: Drivetrain, rpm_in: float, torque_out: float,
                           k_grid: np.ndarray, e_grid: np.ndarray,
                           theta0: float, n_harmonics: int = 12, e_offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Initial ``(y, y_t)``: static preload at the mean mesh stiffness plus the linear periodic response
    to the STE harmonics (mean stiffness), evaluated at input angle ``theta0`` (``t = 0``).
    ``e_offset`` [m] is the non-periodic kinematic error (effects) at ``t = 0``, taken up statically.

    This starts the run close to its steady state, so only the parametric part has to settle.
    """
    z1 = model.pair.z[0]
    kbar = float(np.mean(k_grid))
    c = model.mesh_damping(torque_out)
    f_nom = model.nominal_force(torque_out)
    w = red.w_eta
    Ti = np.linalg.inv(red.T)
    Kr = Ti.T @ red.K @ Ti
    Dr = Ti.T @ red.D @ Ti
    Fr = Ti.T @ red.F
    r = len(w)
    A0 = Kr + kbar * np.outer(w, w)
    ebar = float(np.mean(e_grid)) + float(e_offset)
    rhs = Fr - w * (f_nom - kbar * ebar)
    # gauge: the rigid mode (zero frequency) carries no static deflection
    rigid = red.freqs < 1e-3 * max(red.freqs.max(), 1.0)
    A0 = A0 + np.diag(np.where(rigid, 1.0, 0.0) * np.trace(A0) / r)
    eta = np.linalg.solve(A0, rhs)
    eta_t = np.zeros(r)
    omega = rpm_in * 2 * math.pi / 60
    n = len(e_grid)
    coeff = np.fft.rfft(e_grid) / n
    Kl = Kr + kbar * np.outer(w, w)
    Dl = Dr + c * np.outer(w, w)
    for m in range(1, min(n_harmonics, n // 2 - 1) + 1):
        om = m * z1 * omega
        E = 2 * coeff[m] * np.exp(1j * m * z1 * theta0)
        H = np.linalg.solve(Kl - om**2 * np.eye(r) + 1j * om * Dl, w * (kbar + 1j * om * c) * E)
        eta += H.real
        eta_t += (1j * om * H).real
    return Ti @ eta, Ti @ eta_t
