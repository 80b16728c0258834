"""Frictionless contact with influence coefficients under a prescribed total force.

Find forces ``f >= 0`` and the rigid approach ``delta`` with

    g = h + C f - delta >= 0,   f >= 0,   f . g = 0,   sum(f) = F

(``h`` the initial gaps, ``C`` the compliance matrix [m/N]). Solved with a primal-dual active
set (the classic LTCA iteration of Conry & Seireg): solve the equality system on the active set,
drop negative forces, add penetrating points, until neither occurs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearrom.errors import SolverError


@dataclass(frozen=True)
class ContactSolution:
    """Forces ``f`` [N], approach ``delta`` [m], gaps after loading ``gap`` [m], iterations."""

    f: np.ndarray
    delta: float
    gap: np.ndarray
    iterations: int


def activate_penetrating(h: np.ndarray, C: np.ndarray, idx: np.ndarray, fa: np.ndarray, delta: float,
                         active: np.ndarray, tol: float, iterations: int) -> tuple[ContactSolution | None, float]:
    """One check of an active-set iteration: forces ``fa`` on the active points ``idx`` and approach ``delta``.

    Returns the solution when no inactive point penetrates by more than ``tol`` [m]; otherwise adds the
    penetrating points to ``active`` (in place) and returns ``(None, largest penetration [m])``.
    """
    f = np.zeros(h.size)
    f[idx] = fa
    gap = h + C @ f - delta
    pen = np.flatnonzero((gap < -tol) & ~active)
    if pen.size == 0:
        gap[idx] = 0.0
        return ContactSolution(f=f, delta=delta, gap=gap, iterations=iterations), 0.0
    active[pen] = True
    return None, float(-gap[pen].min())


def solve_contact(C: np.ndarray, h: np.ndarray, force: float, *, tol: float = 1e-12, max_iter: int = 200,
                  where: str = "") -> ContactSolution:
    """Solve the contact problem (see module doc).

    Parameters
    ----------
    C : ndarray (n, n)
        Compliance [m/N], symmetric positive definite.
    h : ndarray (n,)
        Initial gaps [m] (any sign; the smallest closes first).
    force : float
        Total normal force [N] (> 0).
    tol : float
        Allowed penetration [m] at the solution.
    where : str
        Position description for error messages.

    Raises
    ------
    SolverError
        No candidate points, or the active set iteration does not converge.
    """
    h = np.asarray(h, float)
    n = h.size
    if n == 0:
        raise SolverError(f"contact not found{where}: no candidate points on the flanks in the contact zone")
    if not force > 0:
        raise SolverError(f"contact force must be positive{where}, got {force!r}")
    active = np.zeros(n, bool)
    active[np.argmin(h)] = True
    np.zeros(n)
    delta = float(h.min())
    worst = np.inf
    for it in range(1, max_iter + 1):
        idx = np.flatnonzero(active)
        m = idx.size
        A = np.empty((m + 1, m + 1))
        A[:m, :m] = C[np.ix_(idx, idx)]
        A[:m, m] = -1.0
        A[m, :m] = 1.0
        A[m, m] = 0.0
        rhs = np.concatenate([-h[idx], [force]])
        try:
            sol = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:
            raise SolverError(f"singular contact system{where} with {m} active points") from None
        fa, delta = sol[:m], float(sol[m])
        if np.any(fa < 0):
            # drop the most negative forces (all with f < 0 at once converges fast for LTCA)
            active[idx[fa < 0]] = False
            if not active.any():
                active[idx[np.argmax(fa)]] = True
            continue
        sol, worst = activate_penetrating(h, C, idx, fa, delta, active, tol, it)
        if sol is not None:
            return sol
    raise SolverError(
        f"contact active set did not converge{where} after {max_iter} iterations "
        f"(largest penetration {worst * 1e6:.3g} um, {int(active.sum())} active of {n})"
    )


def solve_contact_blocks(blocks: list[np.ndarray], gaps: list[np.ndarray], force: float, *, tol: float = 1e-12,
                         max_iter: int = 200, where: str = "") -> ContactSolution:
    """:func:`solve_contact` for a block-diagonal compliance (uncoupled slices sharing one approach).

    On the active set each block gives ``f_k = delta a_k - b_k`` with ``a_k = C_k^-1 1`` and
    ``b_k = C_k^-1 h_k``; the force balance fixes ``delta``. Cost: the sum of the block cubes.
    """
    sizes = [h.size for h in gaps]
    h = np.concatenate(gaps) if gaps else np.zeros(0)
    if h.size == 0:
        raise SolverError(f"contact not found{where}: no candidate points on the flanks in the contact zone")
    if not force > 0:
        raise SolverError(f"contact force must be positive{where}, got {force!r}")
    starts = np.cumsum([0] + sizes)
    active = np.zeros(h.size, bool)
    active[np.argmin(h)] = True
    worst = np.inf
    for it in range(1, max_iter + 1):
        a = np.zeros(h.size)
        b = np.zeros(h.size)
        for k, C in enumerate(blocks):
            sl = slice(starts[k], starts[k + 1])
            idx = np.flatnonzero(active[sl])
            if idx.size == 0:
                continue
            rhs = np.column_stack([np.ones(idx.size), h[sl][idx]])
            try:
                x = np.linalg.solve(C[np.ix_(idx, idx)], rhs)
            except np.linalg.LinAlgError:
                raise SolverError(f"singular contact block{where}") from None
            a[starts[k] + idx], b[starts[k] + idx] = x[:, 0], x[:, 1]
        delta = (force + b.sum()) / a.sum()
        f = np.where(active, delta * a - b, 0.0)
        if np.any(f[active] < 0):
            active &= ~(f < 0)
            if not active.any():
                active[np.argmax(f)] = True
            continue
        gap = np.concatenate([h[starts[k]:starts[k + 1]] + C @ f[starts[k]:starts[k + 1]] for k, C in enumerate(blocks)])
        gap -= delta
        pen = np.flatnonzero((gap < -tol) & ~active)
        if pen.size == 0:
            gap[active] = 0.0
            return ContactSolution(f=f, delta=float(delta), gap=gap, iterations=it)
        worst = float(-gap[pen].min())
        active[pen] = True
    raise SolverError(
        f"contact active set did not converge{where} after {max_iter} iterations "
        f"(largest penetration {worst * 1e6:.3g} um, {int(active.sum())} active of {h.size})"
    )
