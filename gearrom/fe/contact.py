"""Frictionless contact with influence coefficients under a prescribed total force.

Find forces ``f >= 0`` and the rigid approach ``delta`` with

    g = h + C f - delta >= 0,   f >= 0,   f . g = 0,   sum(f) = F

(``h`` the initial gaps, ``C`` the compliance matrix [m/N]). Solved with a primal-dual active
set (the classic LTCA iteration of Conry & Seireg): solve the equality system on the active set,
drop negative forces, add penetrating points, until neither occurs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from gearrom.errors import SolverError


def single_thread_blas():
    """A context limiting BLAS to one thread for the small dense contact problems: their solves are
    short, and a second BLAS thread only adds synchronisation, which stalls the solve while another
    process holds the other core. A no-op without the optional ``threadpoolctl``."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        import contextlib

        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


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
    ``b_k = C_k^-1 h_k``; the force balance fixes ``delta``. Cost: the sum of the block cubes. The
    iteration runs compiled (:func:`_blocks_active_set`): a helical mesh cycle asks for thousands of
    these solves with a few hundred small block solves each.
    """
    sizes = np.array([h.size for h in gaps], np.int64)
    h = np.concatenate(gaps) if gaps else np.zeros(0)
    if h.size == 0:
        raise SolverError(f"contact not found{where}: no candidate points on the flanks in the contact zone")
    if not force > 0:
        raise SolverError(f"contact force must be positive{where}, got {force!r}")
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    cpad = np.zeros((len(blocks), int(sizes.max()), int(sizes.max())))
    for k, C in enumerate(blocks):
        cpad[k, :sizes[k], :sizes[k]] = C
    try:
        f, delta, gap, it, worst, n_active = _blocks_active_set(cpad, starts, h, float(force), float(tol), int(max_iter))
    except np.linalg.LinAlgError:
        raise SolverError(f"singular contact block{where}") from None
    if it == 0:
        raise SolverError(
            f"contact active set did not converge{where} after {max_iter} iterations "
            f"(largest penetration {worst * 1e6:.3g} um, {n_active} active of {h.size})"
        )
    return ContactSolution(f=f, delta=float(delta), gap=gap, iterations=int(it))


@nb.njit(cache=True, nogil=True)
def _blocks_active_set(cpad, starts, h, force, tol, max_iter):  # pragma: no cover - compiled
    """Active-set iteration of :func:`solve_contact_blocks` on the padded blocks ``cpad`` (nb, m, m).

    Returns ``(f, delta, gap, iterations, largest penetration, active count)``; iterations 0: not
    converged. A singular block raises ``LinAlgError``.
    """
    n = h.size
    nb_ = cpad.shape[0]
    active = np.zeros(n, np.bool_)
    active[np.argmin(h)] = True
    worst = np.inf
    a = np.zeros(n)
    b = np.zeros(n)
    f = np.zeros(n)
    gap = np.zeros(n)
    for it in range(1, max_iter + 1):
        a[:] = 0.0
        b[:] = 0.0
        for k in range(nb_):
            s0, s1 = starts[k], starts[k + 1]
            m = 0
            for i in range(s0, s1):
                if active[i]:
                    m += 1
            if m == 0:
                continue
            idx = np.empty(m, np.int64)
            j = 0
            for i in range(s0, s1):
                if active[i]:
                    idx[j] = i - s0
                    j += 1
            A = np.empty((m, m))
            rhs = np.empty((m, 2))
            for p in range(m):
                for q in range(m):
                    A[p, q] = cpad[k, idx[p], idx[q]]
                rhs[p, 0] = 1.0
                rhs[p, 1] = h[s0 + idx[p]]
            x = np.linalg.solve(A, rhs)  # raises LinAlgError on a singular block
            for p in range(m):
                a[s0 + idx[p]] = x[p, 0]
                b[s0 + idx[p]] = x[p, 1]
        delta = (force + b.sum()) / a.sum()
        neg = False
        for i in range(n):
            f[i] = delta * a[i] - b[i] if active[i] else 0.0
            if active[i] and f[i] < 0:
                neg = True
        if neg:
            best, any_active = 0, False
            for i in range(n):
                if f[i] > f[best]:
                    best = i
                if f[i] < 0:
                    active[i] = False
                any_active = any_active or active[i]
            if not any_active:
                active[best] = True
            continue
        for k in range(nb_):
            s0, s1 = starts[k], starts[k + 1]
            for i in range(s0, s1):
                g = h[i]
                for q in range(s0, s1):
                    g += cpad[k, i - s0, q - s0] * f[q]
                gap[i] = g - delta
        worst_now = 0.0
        found = False
        for i in range(n):
            if gap[i] < -tol and not active[i]:
                if not found or -gap[i] > worst_now:
                    worst_now = -gap[i]
                found = True
                active[i] = True
        if not found:
            for i in range(n):
                if active[i]:
                    gap[i] = 0.0
            return f, delta, gap, it, 0.0, 0
        worst = worst_now
    return f, 0.0, gap, 0, worst, int(active.sum())
