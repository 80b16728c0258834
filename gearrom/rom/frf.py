"""Frequency response with python-control: the linear time-invariant estimate of the DTE.

Linearising the mesh law at the mean stiffness ``k`` gives ``F = F_nom + k (delta - e) + c (delta' - e')``,
i.e. the static TE ``e(t)`` acts as a displacement excitation of a time-invariant system::

    M x'' + D x' + K x = w (k e + c e')          (K, D include k w w^T, c w w^T and Omega G)

With ``v = x' - M^-1 w c e`` the model is proper: states ``(x, v)``, input ``e`` [m], outputs the DTE at
the sensor and clutch sides and the mesh deflection [m]. The GMF harmonic amplitudes follow as
``|H(i m Omega_mesh)| |E_m|`` with ``E_m`` the STE harmonics. What this misses is the parametric
excitation (``(k(theta) - k) (delta - e)``): it moves energy to sidebands and combination frequencies
and shifts resonances, so the time-domain sweep differs most near resonances of mesh-dominated modes
and where the stiffness fluctuation is large (spur), and agrees closely where the stiffness is nearly
constant (the helical rig pair, eps_beta ~ 2).
"""
from __future__ import annotations

import math

import numpy as np

from gearrom.rom.components import RZ
from gearrom.rom.model import Drivetrain

OUTPUTS = ("dte_sensor", "dte_clutch", "delta")


def output_matrix(model: Drivetrain) -> tuple[np.ndarray, list[str]]:
    """Rows of ``C`` (over physical coordinates) for the DTE at each side and the mesh deflection."""
    rb1, rb2 = model.pair.rb
    rows, names = [], []
    for side in ("sensor", "clutch"):
        ei = [e for e in model.encoders if e.side == side and e.shaft == "in"]
        eo = [e for e in model.encoders if e.side == side and e.shaft == "out"]
        if ei and eo:
            c = np.zeros(model.ndof)
            c[model.index(ei[0].station, RZ)] += rb1
            c[model.index(eo[0].station, RZ)] += rb2
            rows.append(c)
            names.append(f"dte_{side}")
    rows.append(model.w.copy())
    names.append("delta")
    return np.array(rows), names


def state_space(model: Drivetrain, rpm_in: float, torque_out: float | None = None):
    """``control.StateSpace`` from the STE excitation ``e`` [m] to DTE sensor/clutch and ``delta`` [m].

    The rigid rotation mode (speed-controlled motor) is kept; it is stable through the motor damping.
    """
    import control

    A, B, C, names = state_matrices(model, rpm_in, torque_out)
    return control.ss(A, B, C, np.zeros((C.shape[0], 1)), inputs=["ste"], outputs=names)


def state_matrices(model: Drivetrain, rpm_in: float, torque_out: float | None = None):
    """``(A, B, C, output names)`` of :func:`state_space` as arrays (states ``(x, v)``, input the STE [m])."""
    torque = float(model.metadata.get("torque_out_Nm", 120.0) if torque_out is None else torque_out)
    M, K, D = model.linear(rpm_in, torque)
    k = model.mesh_stiffness(torque)
    c = model.mesh_damping(torque)
    n = model.ndof
    Minv = np.linalg.inv(M)
    w = model.w
    mw = Minv @ w
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    B = np.concatenate([mw * c, Minv @ (w * k) - Minv @ D @ mw * c])[:, None]
    Cx, names = output_matrix(model)
    return A, B, np.hstack([Cx, np.zeros_like(Cx)]), names


def gmf_estimate(model: Drivetrain, rpms, torque_out: float | None = None, orders: int = 3,
                 output: str = "dte_sensor") -> np.ndarray:
    """Linear estimate of the GMF harmonic amplitudes [m] of ``output`` at each speed, shape (n_rpm, orders).

    The state-space model is rebuilt per speed only through the gyroscopic terms (its mesh part is
    speed independent); the STE harmonics come from the excitation table at ``torque_out``.
    """
    torque = float(model.metadata.get("torque_out_Nm", 120.0) if torque_out is None else torque_out)
    harm = model.excitation.harmonics(torque, orders).ste[1:]
    z1 = model.pair.z[0]
    out = np.zeros((len(rpms), orders))
    for i, rpm in enumerate(rpms):
        sys = state_space(model, rpm, torque)
        j = list(sys.output_labels).index(output)
        om = np.arange(1, orders + 1) * z1 * rpm * 2 * math.pi / 60
        resp = np.asarray(sys.frequency_response(om).complex).reshape(sys.noutputs, 1, orders)
        out[i] = np.abs(resp[j, 0, :]) * np.abs(harm)
    return out


def plot_transfer(model: Drivetrain, rpm_in: float, torque_out: float | None = None, fmax: float = 10e3,
                  n: int = 800):
    """Bode magnitude of DTE (sensor, clutch) and mesh deflection per unit STE, with GMF orders marked."""
    from gearrom.plotting import subplots

    sys = state_space(model, rpm_in, torque_out)
    f = np.linspace(1.0, fmax, n)
    resp = np.asarray(sys.frequency_response(2 * math.pi * f).complex).reshape(sys.noutputs, 1, n)
    fig, ax = subplots(figsize=(8, 4.5))
    for j, name in enumerate(sys.output_labels):
        ax.semilogy(f, np.abs(resp[j, 0]), lw=0.9, label=f"{name} / STE")
    gmf = model.pair.z[0] * rpm_in / 60
    for m in (1, 2, 3):
        ax.axvline(m * gmf, color="k", ls=":", lw=0.7)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|H| [m/m]")
    ax.set_title(f"linear transfer from STE at {rpm_in:.0f} rpm (dotted: GMF x1-3)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
