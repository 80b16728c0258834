"""Compiled (numba) kernels of the sampled-quadrature decoder, the forward-run selection and the
edge checks and interpolation of :class:`~gearrom.signal.edges.EdgeStream`.

:func:`decode_chunk` does in one pass over a chunk of samples what
:class:`~gearrom.signal.quadrature.QuadratureDecoder` specifies: Schmitt trigger of A, B and
index (state carried across chunks), quadrature phase step and direction, illegal transitions,
crossing time interpolated between the two samples around a switch, x1/x2/x4 selection and the
x4 position at each index pulse. Sample times are either given (``t``) or computed from the
sample index and the sample rate, so no time array is built. The floating-point operations are
those of the vectorised definition in the same order, so both give bit-identical edge times.

:func:`median4` and :func:`hermite_grid` compute the local reference interval and the cubic
Hermite angle on the grid with the same floating-point operations, in the same order, as their
vectorised statements (kept in the tests), so both give bit-identical results without the
per-edge and per-grid-sample temporary arrays.

State arrays (one per encoder, owned by the decoder):

- ``si`` (int64): level of A, B, Z (-1: not known yet), phase (-1: no sample yet), x4
  position, direction of the last legal step, illegal transitions, first illegal seen (0/1).
- ``sf`` (float64): previous sample of A, of B, previous sample time (s), time of the first
  illegal transition (s).
"""
from __future__ import annotations

import numba as nb
import numpy as np

# state indices
LA, LB, LZ, PHASE, POS, LAST_DIR, ILLEGAL, HAS_ILLEGAL = range(8)
XA, XB, T_PREV, ILLEGAL_T = range(4)
N_INT, N_FLOAT = 8, 4

_PHASE = np.array([0, 3, 1, 2], np.int64)  # index 2*A + B -> quadrature phase

_JIT = dict(nogil=True, cache=True, error_model="numpy")


@nb.njit(**_JIT)
def _init_level(x, lo, hi):
    """Level before the first sample when unknown: the first decided level of the chunk, else 0."""
    for j in range(x.size):
        v = np.float64(x[j])
        if v > hi:
            return 1
        if v < lo:
            return 0
    return 0


@nb.njit(**_JIT)
def _cross(x0, x1, t0, t1, lvl, interp):
    """Time where the signal crosses ``lvl`` between samples (t0, x0) and (t1, x1)."""
    if not interp:
        return t1
    q = (lvl - x0) / (x1 - x0)
    if q != q:
        q = 1.0
    elif q < 0.0:
        q = 0.0
    elif q > 1.0:
        q = 1.0
    return t0 + q * (t1 - t0)


@nb.njit(**_JIT)
def decode_chunk(a, b, z, t, row0, rate, levels, k, interp, si, sf, out_t, out_s, out_r, out_z):
    """Decode one chunk of samples into edges; returns ``(edges written, index pulses written)``.

    Parameters
    ----------
    a, b, z : ndarray
        Samples of A, B and index (``z`` empty: no index channel), same dtype.
    t : ndarray of float64
        Sample times (s), or empty: time of sample ``row0 + j`` is ``(row0 + j) / rate``.
    row0 : int
        Index of the first sample in the record.
    rate : float
        Sample rate (Hz) when ``t`` is empty.
    levels : ndarray of float64
        ``lo, hi`` of A, B and Z.
    k : int
        Decoding factor (1, 2, 4).
    interp : bool
        Interpolate the crossing time (else the time of the first sample past the switch).
    si, sf : ndarray
        Decoder state (see the module docstring), updated in place.
    out_t, out_s, out_r : ndarray
        Edge times (s), signs and sample indices; at least ``2 * len(a)`` long.
    out_z : ndarray of int64
        x4 positions at the index pulses; at least ``len(a)`` long.
    """
    m = a.size
    if m == 0:
        return 0, 0
    has_t = t.size > 0
    has_z = z.size > 0
    alo, ahi, blo, bhi, zlo, zhi = levels[0], levels[1], levels[2], levels[3], levels[4], levels[5]
    la = si[LA] if si[LA] >= 0 else _init_level(a, alo, ahi)
    lb = si[LB] if si[LB] >= 0 else _init_level(b, blo, bhi)
    lz = 0
    if has_z:
        lz = si[LZ] if si[LZ] >= 0 else _init_level(z, zlo, zhi)
    phase = si[PHASE]
    pos = si[POS]
    last_dir = si[LAST_DIR]
    xa0, xb0, t0 = sf[XA], sf[XB], sf[T_PREV]
    off = 1 if k == 2 else 3
    div = 4 // k
    n = 0
    nz = 0
    pending = False  # an index pulse rose at the previous sample, time t_rise
    t_rise = 0.0
    for j in range(m):
        xa = np.float64(a[j])
        xb = np.float64(b[j])
        tj = t[j] if has_t else np.float64(row0 + j) / rate
        na = 1 if xa > ahi else (0 if xa < alo else la)
        nb_ = 1 if xb > bhi else (0 if xb < blo else lb)
        ph = _PHASE[2 * na + nb_]
        if phase < 0:  # very first sample of the record: no previous sample, no edge
            phase = ph
            pos = ph
        step = (ph - phase + 4) % 4
        zp = pos  # x4 position for a pending index pulse: edges up to t_rise
        if step != 0:
            if step == 1:
                s = 1
            elif step == 3:
                s = -1
            else:  # both channels switched within one sample
                s = last_dir
                si[ILLEGAL] += 1
                if si[HAS_ILLEGAL] == 0:
                    si[HAS_ILLEGAL] = 1
                    sf[ILLEGAL_T] = tj
            last_dir = s
            da = na != la
            db = nb_ != lb
            ta = _cross(xa0, xa, t0, tj, ahi if na == 1 else alo, interp) if da else 0.0
            tb = _cross(xb0, xb, t0, tj, bhi if nb_ == 1 else blo, interp) if db else 0.0
            a_first = da and (not db or ta <= tb)
            for e in range(2):
                is_a = a_first if e == 0 else not a_first
                if is_a and not da or (not is_a) and not db:
                    continue
                te = ta if is_a else tb
                before = pos
                pos += s
                if pending and te <= t_rise:
                    zp = pos
                if k == 4 or (is_a and (pos + off) // div != (before + off) // div):
                    out_t[n] = te
                    out_s[n] = s
                    out_r[n] = row0 + j
                    n += 1
        if pending:
            out_z[nz] = zp
            nz += 1
            pending = False
        if has_z:
            xz = np.float64(z[j])
            nzl = 1 if xz > zhi else (0 if xz < zlo else lz)
            if nzl == 1 and lz == 0:
                pending = True
                t_rise = tj
            lz = nzl
        phase = ph
        la, lb = na, nb_
        xa0, xb0, t0 = xa, xb, tj
    if pending:  # rose at the last sample: edges of the next chunk are not counted
        out_z[nz] = pos
        nz += 1
    si[LA], si[LB], si[PHASE], si[POS], si[LAST_DIR] = la, lb, phase, pos, last_dir
    if has_z:
        si[LZ] = lz
    sf[XA], sf[XB], sf[T_PREV] = xa0, xb0, t0
    return n, nz


@nb.njit(**_JIT)
def new_positions(sign, rev, state):
    """Edges reaching a new largest position, and whether the position fell back by two edges or more
    between each of them and the previous one.

    ``state`` (int64[5]: position, largest position, edges seen, fallen back by two since the last
    new position, new positions so far) carries over from chunk to chunk; zeros at the start of a
    channel.

    Returns ``(new, brk, first_deep)``: indices of the new-position edges, reversal flag per such edge
    (False for the channel's first), index of the first edge two or more below the running maximum
    (-1: none); indices are into this chunk.
    """
    n = sign.size
    new = np.empty(n, np.int64)
    brk = np.zeros(n, np.bool_)
    pos, mx, seen, deep_since, n_new = state[0], state[1], state[2], state[3] != 0, state[4]
    first_deep = -1
    m = 0
    for i in range(n):
        s = -np.int64(sign[i]) if rev else np.int64(sign[i])
        pos += s
        if pos > mx:
            new[m] = i
            brk[m] = deep_since and m + n_new > 0
            m += 1
            deep_since = False
        # the start position counts as reached only for the channel's first edge
        mx = pos if (seen == 0 and i == 0) or pos > mx else mx
        if mx - pos >= 2:
            deep_since = True
            if first_deep < 0:
                first_deep = i
    state[0], state[1], state[2], state[3], state[4] = pos, mx, seen + n, 1 if deep_since else 0, n_new + m
    return new[:m], brk[:m], first_deep


@nb.njit(**_JIT)
def longest_stretch(t, new, brk, standstill_s, trim):
    """First longest (by duration) stretch of the edges ``new`` between breaks: ``(start, stop)``
    indices into ``new``.

    A stretch breaks before edge ``new[m]`` where ``brk[m]`` or, with ``trim``, where the time since
    the previous edge exceeds ``standstill_s``. ``t`` holds the times of all edges.
    """
    n = new.size
    best_a, best_b = 0, n
    best = -np.inf
    a = 0
    for m in range(1, n + 1):
        if m < n and not (brk[m] or (trim and t[new[m]] - t[new[m - 1]] > standstill_s)):
            continue
        dur = t[new[m - 1]] - t[new[a]]
        if dur > best:
            best, best_a, best_b = dur, a, m
        a = m
    return best_a, best_b


@nb.njit(**_JIT)
def median4(ext, p, out):
    """Mean of the middle two of ``ext[j], ext[j+p], ext[j+3p], ext[j+4p]`` into ``out[j]``.

    That is ``(sum - max - min) / 2`` of the four intervals ``2p`` and ``p`` edges before and ``p``
    and ``2p`` after interval ``j + 2p`` of ``ext`` (the padded intervals); ``out`` has
    ``len(ext) - 4p`` entries.
    """
    for j in range(out.size):
        a, b, c, e = ext[j], ext[j + p], ext[j + 3 * p], ext[j + 4 * p]
        hi = max(max(a, b), max(c, e))
        lo = min(min(a, b), min(c, e))
        out[j] = (a + b + c + e - hi - lo) * 0.5


@nb.njit(**_JIT)
def _slope(bt, bc, j, n):
    """Centred-difference slope (counts/s) at edge ``j`` (one-sided at the ends of the buffer)."""
    jl = max(j - 1, 0)
    jr = min(j + 1, n - 1)
    return (bc[jr] - bc[jl]) / (bt[jr] - bt[jl])


@nb.njit(**_JIT)
def hermite_grid(bt, bc, k0, fs, dtheta, out):
    """Cubic Hermite through the edges ``(bt, bc)`` at the grid times ``(k0 + m) / fs``, times ``dtheta``.

    Parameters
    ----------
    bt : ndarray of float64
        Edge times (s), non-decreasing, at least 2.
    bc : ndarray of float64
        Edge counts at those times.
    k0 : int
        Grid index of ``out[0]``.
    fs : float
        Grid rate (Hz).
    dtheta : float
        Angle per count (rad).
    out : ndarray of float64
        Angles (rad), written in place.

    Notes
    -----
    The interval of grid time ``tg`` is the last edge at or before it (``searchsorted(bt, tg,
    "right") - 1``) clipped to ``0 .. n-2``; the grid times increase, so one forward walk finds
    them all.
    """
    n = bt.size
    i = 0
    for m in range(out.size):
        tg = np.float64(k0 + m) / fs
        while i < n - 2 and bt[i + 1] <= tg:
            i += 1
        h = bt[i + 1] - bt[i]
        u = (tg - bt[i]) / h
        u2 = u * u
        u3 = u * u * u
        rel = ((-2 * u3 + 3 * u2) * (bc[i + 1] - bc[i]) + (u3 - 2 * u2 + u) * h * _slope(bt, bc, i, n)
               + (u3 - u2) * h * _slope(bt, bc, i + 1, n))
        out[m] = (bc[i] + rel) * dtheta
