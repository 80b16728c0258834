"""Element kernels: one-point total-Lagrangian St Venant-Kirchhoff Q4 / Hex8 with hourglass control.

For element e with reference mean gradients B_a (1/m) and volume V0:

    F = I + sum_a u_a (x) B_a,   E = (F^T F - I) / 2,   S = lambda tr(E) I + 2 mu E,   P = F S,
    f_a^int = V0 P B_a,          W = V0 (lambda tr(E)^2 / 2 + mu E:E).

Plane strain: F is 2x2 with F_33 = 1, so E_33 = 0 and S is the 2x2 block. The Flanagan-Belytschko
hourglass generalized displacements q_k = sum_a gamma_ak u_a and velocities qd_k give forces
f_a = gamma_ak (k_hg q_k + c_hg qd_k). Because gamma_k annihilates every linear field, q_k is
unchanged by rigid translation and rotates with the body under rigid rotation, so the stiffness
term is objective for large rotations and its energy k_hg |q|^2 / 2 is rotation invariant.

The kernels ADD the internal+hourglass force with a minus sign into ``f`` (the residual), and return
(internal energy, hourglass energy, hourglass viscous power).
"""
from __future__ import annotations

from numba import njit


@njit(cache=True, fastmath=True, inline="always")
def svk_2d(F00, F01, F10, F11, lam, mu):
    """Plane-strain St Venant-Kirchhoff: first Piola-Kirchhoff stress P = F S (Pa) and the energy
    density (J/m^3) of the 2x2 deformation gradient F (F_33 = 1)."""
    E00 = 0.5 * (F00 * F00 + F10 * F10 - 1.0)
    E11 = 0.5 * (F01 * F01 + F11 * F11 - 1.0)
    E01 = 0.5 * (F00 * F01 + F10 * F11)
    tr = E00 + E11
    S00 = lam * tr + 2.0 * mu * E00
    S11 = lam * tr + 2.0 * mu * E11
    S01 = 2.0 * mu * E01
    psi = 0.5 * lam * tr * tr + mu * (E00 * E00 + E11 * E11 + 2.0 * E01 * E01)
    return (F00 * S00 + F01 * S01, F00 * S01 + F01 * S11,
            F10 * S00 + F11 * S01, F10 * S01 + F11 * S11, psi)


@njit(cache=True, fastmath=True, inline="always")
def svk_3d(F00, F01, F02, F10, F11, F12, F20, F21, F22, lam, mu):
    """St Venant-Kirchhoff: P = F S (Pa, row-major 3x3) and the energy density (J/m^3) of F."""
    E00 = 0.5 * (F00 * F00 + F10 * F10 + F20 * F20 - 1.0)
    E11 = 0.5 * (F01 * F01 + F11 * F11 + F21 * F21 - 1.0)
    E22 = 0.5 * (F02 * F02 + F12 * F12 + F22 * F22 - 1.0)
    E01 = 0.5 * (F00 * F01 + F10 * F11 + F20 * F21)
    E02 = 0.5 * (F00 * F02 + F10 * F12 + F20 * F22)
    E12 = 0.5 * (F01 * F02 + F11 * F12 + F21 * F22)
    tr = E00 + E11 + E22
    m2 = 2.0 * mu
    S00 = lam * tr + m2 * E00
    S11 = lam * tr + m2 * E11
    S22 = lam * tr + m2 * E22
    S01 = m2 * E01
    S02 = m2 * E02
    S12 = m2 * E12
    psi = 0.5 * lam * tr * tr + mu * (E00 * E00 + E11 * E11 + E22 * E22 + 2.0 * (E01 * E01 + E02 * E02 + E12 * E12))
    return (F00 * S00 + F01 * S01 + F02 * S02, F00 * S01 + F01 * S11 + F02 * S12, F00 * S02 + F01 * S12 + F02 * S22,
            F10 * S00 + F11 * S01 + F12 * S02, F10 * S01 + F11 * S11 + F12 * S12, F10 * S02 + F11 * S12 + F12 * S22,
            F20 * S00 + F21 * S01 + F22 * S02, F20 * S01 + F21 * S11 + F22 * S12, F20 * S02 + F21 * S12 + F22 * S22,
            psi)


@njit(cache=True, fastmath=True, inline="always")
def q4_element(e, conn, u, v, B, V0, gamma, khg, chg, lam, mu, f):
    """Residual contribution of Q4 element ``e``; returns (W_int, W_hg, P_hgvisc) in J, J, W."""
    n0 = conn[e, 0]
    n1 = conn[e, 1]
    n2 = conn[e, 2]
    n3 = conn[e, 3]
    ux0 = u[n0, 0]; uy0 = u[n0, 1]
    ux1 = u[n1, 0]; uy1 = u[n1, 1]
    ux2 = u[n2, 0]; uy2 = u[n2, 1]
    ux3 = u[n3, 0]; uy3 = u[n3, 1]
    b0x = B[e, 0, 0]; b0y = B[e, 0, 1]
    b1x = B[e, 1, 0]; b1y = B[e, 1, 1]
    b2x = B[e, 2, 0]; b2y = B[e, 2, 1]
    b3x = B[e, 3, 0]; b3y = B[e, 3, 1]
    F11 = 1.0 + ux0 * b0x + ux1 * b1x + ux2 * b2x + ux3 * b3x
    F12 = ux0 * b0y + ux1 * b1y + ux2 * b2y + ux3 * b3y
    F21 = uy0 * b0x + uy1 * b1x + uy2 * b2x + uy3 * b3x
    F22 = 1.0 + uy0 * b0y + uy1 * b1y + uy2 * b2y + uy3 * b3y
    P11, P12, P21, P22, psi = svk_2d(F11, F12, F21, F22, lam, mu)
    vol = V0[e]
    P11 *= vol; P12 *= vol; P21 *= vol; P22 *= vol
    wint = vol * psi
    g0 = gamma[e, 0, 0]; g1 = gamma[e, 1, 0]; g2 = gamma[e, 2, 0]; g3 = gamma[e, 3, 0]
    qx = g0 * ux0 + g1 * ux1 + g2 * ux2 + g3 * ux3
    qy = g0 * uy0 + g1 * uy1 + g2 * uy2 + g3 * uy3
    k = khg[e]
    c = chg[e]
    hx = k * qx
    hy = k * qy
    whg = 0.5 * k * (qx * qx + qy * qy)
    phg = 0.0
    if c > 0.0:
        qdx = g0 * v[n0, 0] + g1 * v[n1, 0] + g2 * v[n2, 0] + g3 * v[n3, 0]
        qdy = g0 * v[n0, 1] + g1 * v[n1, 1] + g2 * v[n2, 1] + g3 * v[n3, 1]
        hx += c * qdx
        hy += c * qdy
        phg = c * (qdx * qdx + qdy * qdy)
    f[n0, 0] -= P11 * b0x + P12 * b0y + g0 * hx
    f[n0, 1] -= P21 * b0x + P22 * b0y + g0 * hy
    f[n1, 0] -= P11 * b1x + P12 * b1y + g1 * hx
    f[n1, 1] -= P21 * b1x + P22 * b1y + g1 * hy
    f[n2, 0] -= P11 * b2x + P12 * b2y + g2 * hx
    f[n2, 1] -= P21 * b2x + P22 * b2y + g2 * hy
    f[n3, 0] -= P11 * b3x + P12 * b3y + g3 * hx
    f[n3, 1] -= P21 * b3x + P22 * b3y + g3 * hy
    return wint, whg, phg


@njit(cache=True, fastmath=True, inline="always")
def hex8_element(e, conn, u, v, B, V0, gamma, khg, chg, lam, mu, f):
    """Residual contribution of Hex8 element ``e``; returns (W_int, W_hg, P_hgvisc)."""
    F00 = 1.0; F01 = 0.0; F02 = 0.0
    F10 = 0.0; F11 = 1.0; F12 = 0.0
    F20 = 0.0; F21 = 0.0; F22 = 1.0
    q00 = 0.0; q01 = 0.0; q02 = 0.0; q03 = 0.0
    q10 = 0.0; q11 = 0.0; q12 = 0.0; q13 = 0.0
    q20 = 0.0; q21 = 0.0; q22 = 0.0; q23 = 0.0
    for a in range(8):
        n = conn[e, a]
        ux = u[n, 0]; uy = u[n, 1]; uz = u[n, 2]
        bx = B[e, a, 0]; by = B[e, a, 1]; bz = B[e, a, 2]
        F00 += ux * bx; F01 += ux * by; F02 += ux * bz
        F10 += uy * bx; F11 += uy * by; F12 += uy * bz
        F20 += uz * bx; F21 += uz * by; F22 += uz * bz
        g0 = gamma[e, a, 0]; g1 = gamma[e, a, 1]; g2 = gamma[e, a, 2]; g3 = gamma[e, a, 3]
        q00 += g0 * ux; q01 += g1 * ux; q02 += g2 * ux; q03 += g3 * ux
        q10 += g0 * uy; q11 += g1 * uy; q12 += g2 * uy; q13 += g3 * uy
        q20 += g0 * uz; q21 += g1 * uz; q22 += g2 * uz; q23 += g3 * uz
    P00, P01, P02, P10, P11, P12, P20, P21, P22, psi = svk_3d(F00, F01, F02, F10, F11, F12, F20, F21, F22, lam, mu)
    vol = V0[e]
    P00 *= vol; P01 *= vol; P02 *= vol
    P10 *= vol; P11 *= vol; P12 *= vol
    P20 *= vol; P21 *= vol; P22 *= vol
    wint = vol * psi
    k = khg[e]
    c = chg[e]
    whg = 0.5 * k * (q00 * q00 + q01 * q01 + q02 * q02 + q03 * q03 + q10 * q10 + q11 * q11
                     + q12 * q12 + q13 * q13 + q20 * q20 + q21 * q21 + q22 * q22 + q23 * q23)
    q00 *= k; q01 *= k; q02 *= k; q03 *= k
    q10 *= k; q11 *= k; q12 *= k; q13 *= k
    q20 *= k; q21 *= k; q22 *= k; q23 *= k
    phg = 0.0
    if c > 0.0:
        d00 = 0.0; d01 = 0.0; d02 = 0.0; d03 = 0.0
        d10 = 0.0; d11 = 0.0; d12 = 0.0; d13 = 0.0
        d20 = 0.0; d21 = 0.0; d22 = 0.0; d23 = 0.0
        for a in range(8):
            n = conn[e, a]
            vx = v[n, 0]; vy = v[n, 1]; vz = v[n, 2]
            g0 = gamma[e, a, 0]; g1 = gamma[e, a, 1]; g2 = gamma[e, a, 2]; g3 = gamma[e, a, 3]
            d00 += g0 * vx; d01 += g1 * vx; d02 += g2 * vx; d03 += g3 * vx
            d10 += g0 * vy; d11 += g1 * vy; d12 += g2 * vy; d13 += g3 * vy
            d20 += g0 * vz; d21 += g1 * vz; d22 += g2 * vz; d23 += g3 * vz
        phg = c * (d00 * d00 + d01 * d01 + d02 * d02 + d03 * d03 + d10 * d10 + d11 * d11
                   + d12 * d12 + d13 * d13 + d20 * d20 + d21 * d21 + d22 * d22 + d23 * d23)
        q00 += c * d00; q01 += c * d01; q02 += c * d02; q03 += c * d03
        q10 += c * d10; q11 += c * d11; q12 += c * d12; q13 += c * d13
        q20 += c * d20; q21 += c * d21; q22 += c * d22; q23 += c * d23
    for a in range(8):
        n = conn[e, a]
        bx = B[e, a, 0]; by = B[e, a, 1]; bz = B[e, a, 2]
        g0 = gamma[e, a, 0]; g1 = gamma[e, a, 1]; g2 = gamma[e, a, 2]; g3 = gamma[e, a, 3]
        f[n, 0] -= P00 * bx + P01 * by + P02 * bz + g0 * q00 + g1 * q01 + g2 * q02 + g3 * q03
        f[n, 1] -= P10 * bx + P11 * by + P12 * bz + g0 * q10 + g1 * q11 + g2 * q12 + g3 * q13
        f[n, 2] -= P20 * bx + P21 * by + P22 * bz + g0 * q20 + g1 * q21 + g2 * q22 + g3 * q23
    return wint, whg, phg


@njit(cache=True, fastmath=True, inline="always")
def q4_full_element(e, conn, u, Bg, Wg, shape, rot, lam, mu, f):
    """Residual contribution of a fully integrated (2x2 Gauss) Q4 element ``e``; returns W_int in J.

    The same total-Lagrangian St Venant-Kirchhoff law as the one-point kernels, evaluated at every
    Gauss point g with the point gradients ``Bg[s, g]`` and weights ``Wg[s, g]`` (det J times the
    thickness) of the element's shape ``s = shape[e]``, turned in plane by ``rot[e]`` (cos, sin), on the
    displacements relative to node 0, as :func:`hex8_full_element`: f_a -= sum_g Wg P_g b_a. The element
    has no zero-energy modes besides rigid motion, so it needs no hourglass control and has no hourglass
    energy.
    """
    n0 = conn[e, 0]; n1 = conn[e, 1]; n2 = conn[e, 2]; n3 = conn[e, 3]
    s = shape[e]
    c = rot[e, 0]; sn = rot[e, 1]
    u0x = u[n0, 0]; u0y = u[n0, 1]
    dx = u[n1, 0] - u0x; dy = u[n1, 1] - u0y
    ux1 = c * dx + sn * dy; uy1 = c * dy - sn * dx
    dx = u[n2, 0] - u0x; dy = u[n2, 1] - u0y
    ux2 = c * dx + sn * dy; uy2 = c * dy - sn * dx
    dx = u[n3, 0] - u0x; dy = u[n3, 1] - u0y
    ux3 = c * dx + sn * dy; uy3 = c * dy - sn * dx
    fx1 = 0.0; fy1 = 0.0; fx2 = 0.0; fy2 = 0.0; fx3 = 0.0; fy3 = 0.0
    wint = 0.0
    for g in range(4):
        w = Wg[s, g]
        b1x = Bg[s, g, 1, 0]; b1y = Bg[s, g, 1, 1]
        b2x = Bg[s, g, 2, 0]; b2y = Bg[s, g, 2, 1]
        b3x = Bg[s, g, 3, 0]; b3y = Bg[s, g, 3, 1]
        F00 = 1.0 + ux1 * b1x + ux2 * b2x + ux3 * b3x
        F01 = ux1 * b1y + ux2 * b2y + ux3 * b3y
        F10 = uy1 * b1x + uy2 * b2x + uy3 * b3x
        F11 = 1.0 + uy1 * b1y + uy2 * b2y + uy3 * b3y
        P00, P01, P10, P11, psi = svk_2d(F00, F01, F10, F11, lam, mu)
        P00 *= w; P01 *= w; P10 *= w; P11 *= w
        wint += w * psi
        fx1 += P00 * b1x + P01 * b1y; fy1 += P10 * b1x + P11 * b1y
        fx2 += P00 * b2x + P01 * b2y; fy2 += P10 * b2x + P11 * b2y
        fx3 += P00 * b3x + P01 * b3y; fy3 += P10 * b3x + P11 * b3y
    fx0 = 0.0; fy0 = 0.0
    gx = c * fx1 - sn * fy1; gy = sn * fx1 + c * fy1
    f[n1, 0] -= gx; f[n1, 1] -= gy
    fx0 += gx; fy0 += gy
    gx = c * fx2 - sn * fy2; gy = sn * fx2 + c * fy2
    f[n2, 0] -= gx; f[n2, 1] -= gy
    fx0 += gx; fy0 += gy
    gx = c * fx3 - sn * fy3; gy = sn * fx3 + c * fy3
    f[n3, 0] -= gx; f[n3, 1] -= gy
    fx0 += gx; fy0 += gy
    f[n0, 0] += fx0; f[n0, 1] += fy0
    return wint


@njit(cache=True, fastmath=True, inline="always")
def hex8_full_element(e, conn, u, Bg, Wg, shape, rot, lam, mu, f):
    """Residual contribution of a fully integrated (2x2x2 Gauss) Hex8 element ``e``; returns W_int in J
    (as :func:`q4_full_element`).

    The element is a copy of shape ``s = shape[e]`` (gradients ``Bg[s]``, weights ``Wg[s]`` in the shape's
    canonical frame, :func:`gearrom.fe.explicit.geometry.congruent_shapes`) turned about z by ``rot[e]``
    (cos, sin). F is formed from the displacements relative to node 0, d_a = u_a - u_0 (a = 1..7), turned
    into that frame: F = I + sum_a R^T d_a (x) b_a. Rigid translation then leaves F = I exactly, whatever the
    rounding of the gradients: the displacements of a spinning gear (its rigid rotation, up to its radius)
    never meet the rounding of sum_a b_a = 0, which would strain the elements. The forces are the exact
    derivative of that energy (f_a = R f_a^s, f_0 = -sum_a f_a), so the discrete model stays conservative.
    The displacements are read once and the forces summed over the Gauss points in local variables, then
    added to ``f`` once: the compiler cannot tell ``u`` and ``f`` apart, so a force written inside the
    Gauss loop would force every displacement to be read again."""
    n0 = conn[e, 0]; n1 = conn[e, 1]; n2 = conn[e, 2]; n3 = conn[e, 3]
    n4 = conn[e, 4]; n5 = conn[e, 5]; n6 = conn[e, 6]; n7 = conn[e, 7]
    s = shape[e]
    c = rot[e, 0]; sn = rot[e, 1]
    u0x = u[n0, 0]; u0y = u[n0, 1]; u0z = u[n0, 2]
    dx = u[n1, 0] - u0x; dy = u[n1, 1] - u0y
    ux1 = c * dx + sn * dy; uy1 = c * dy - sn * dx; uz1 = u[n1, 2] - u0z
    dx = u[n2, 0] - u0x; dy = u[n2, 1] - u0y
    ux2 = c * dx + sn * dy; uy2 = c * dy - sn * dx; uz2 = u[n2, 2] - u0z
    dx = u[n3, 0] - u0x; dy = u[n3, 1] - u0y
    ux3 = c * dx + sn * dy; uy3 = c * dy - sn * dx; uz3 = u[n3, 2] - u0z
    dx = u[n4, 0] - u0x; dy = u[n4, 1] - u0y
    ux4 = c * dx + sn * dy; uy4 = c * dy - sn * dx; uz4 = u[n4, 2] - u0z
    dx = u[n5, 0] - u0x; dy = u[n5, 1] - u0y
    ux5 = c * dx + sn * dy; uy5 = c * dy - sn * dx; uz5 = u[n5, 2] - u0z
    dx = u[n6, 0] - u0x; dy = u[n6, 1] - u0y
    ux6 = c * dx + sn * dy; uy6 = c * dy - sn * dx; uz6 = u[n6, 2] - u0z
    dx = u[n7, 0] - u0x; dy = u[n7, 1] - u0y
    ux7 = c * dx + sn * dy; uy7 = c * dy - sn * dx; uz7 = u[n7, 2] - u0z
    fx1 = 0.0; fy1 = 0.0; fz1 = 0.0; fx2 = 0.0; fy2 = 0.0; fz2 = 0.0; fx3 = 0.0; fy3 = 0.0; fz3 = 0.0
    fx4 = 0.0; fy4 = 0.0; fz4 = 0.0; fx5 = 0.0; fy5 = 0.0; fz5 = 0.0
    fx6 = 0.0; fy6 = 0.0; fz6 = 0.0; fx7 = 0.0; fy7 = 0.0; fz7 = 0.0
    wint = 0.0
    for g in range(8):
        bx1 = Bg[s, g, 1, 0]; by1 = Bg[s, g, 1, 1]; bz1 = Bg[s, g, 1, 2]
        bx2 = Bg[s, g, 2, 0]; by2 = Bg[s, g, 2, 1]; bz2 = Bg[s, g, 2, 2]
        bx3 = Bg[s, g, 3, 0]; by3 = Bg[s, g, 3, 1]; bz3 = Bg[s, g, 3, 2]
        bx4 = Bg[s, g, 4, 0]; by4 = Bg[s, g, 4, 1]; bz4 = Bg[s, g, 4, 2]
        bx5 = Bg[s, g, 5, 0]; by5 = Bg[s, g, 5, 1]; bz5 = Bg[s, g, 5, 2]
        bx6 = Bg[s, g, 6, 0]; by6 = Bg[s, g, 6, 1]; bz6 = Bg[s, g, 6, 2]
        bx7 = Bg[s, g, 7, 0]; by7 = Bg[s, g, 7, 1]; bz7 = Bg[s, g, 7, 2]
        F00 = (1.0 + ux1 * bx1 + ux2 * bx2 + ux3 * bx3
               + ux4 * bx4 + ux5 * bx5 + ux6 * bx6 + ux7 * bx7)
        F01 = (ux1 * by1 + ux2 * by2 + ux3 * by3
               + ux4 * by4 + ux5 * by5 + ux6 * by6 + ux7 * by7)
        F02 = (ux1 * bz1 + ux2 * bz2 + ux3 * bz3
               + ux4 * bz4 + ux5 * bz5 + ux6 * bz6 + ux7 * bz7)
        F10 = (uy1 * bx1 + uy2 * bx2 + uy3 * bx3
               + uy4 * bx4 + uy5 * bx5 + uy6 * bx6 + uy7 * bx7)
        F11 = (1.0 + uy1 * by1 + uy2 * by2 + uy3 * by3
               + uy4 * by4 + uy5 * by5 + uy6 * by6 + uy7 * by7)
        F12 = (uy1 * bz1 + uy2 * bz2 + uy3 * bz3
               + uy4 * bz4 + uy5 * bz5 + uy6 * bz6 + uy7 * bz7)
        F20 = (uz1 * bx1 + uz2 * bx2 + uz3 * bx3
               + uz4 * bx4 + uz5 * bx5 + uz6 * bx6 + uz7 * bx7)
        F21 = (uz1 * by1 + uz2 * by2 + uz3 * by3
               + uz4 * by4 + uz5 * by5 + uz6 * by6 + uz7 * by7)
        F22 = (1.0 + uz1 * bz1 + uz2 * bz2 + uz3 * bz3
               + uz4 * bz4 + uz5 * bz5 + uz6 * bz6 + uz7 * bz7)
        P00, P01, P02, P10, P11, P12, P20, P21, P22, psi = svk_3d(F00, F01, F02, F10, F11, F12, F20, F21, F22,
                                                                  lam, mu)
        w = Wg[s, g]
        wint += w * psi
        P00 *= w; P01 *= w; P02 *= w
        P10 *= w; P11 *= w; P12 *= w
        P20 *= w; P21 *= w; P22 *= w
        fx1 += P00 * bx1 + P01 * by1 + P02 * bz1
        fy1 += P10 * bx1 + P11 * by1 + P12 * bz1
        fz1 += P20 * bx1 + P21 * by1 + P22 * bz1
        fx2 += P00 * bx2 + P01 * by2 + P02 * bz2
        fy2 += P10 * bx2 + P11 * by2 + P12 * bz2
        fz2 += P20 * bx2 + P21 * by2 + P22 * bz2
        fx3 += P00 * bx3 + P01 * by3 + P02 * bz3
        fy3 += P10 * bx3 + P11 * by3 + P12 * bz3
        fz3 += P20 * bx3 + P21 * by3 + P22 * bz3
        fx4 += P00 * bx4 + P01 * by4 + P02 * bz4
        fy4 += P10 * bx4 + P11 * by4 + P12 * bz4
        fz4 += P20 * bx4 + P21 * by4 + P22 * bz4
        fx5 += P00 * bx5 + P01 * by5 + P02 * bz5
        fy5 += P10 * bx5 + P11 * by5 + P12 * bz5
        fz5 += P20 * bx5 + P21 * by5 + P22 * bz5
        fx6 += P00 * bx6 + P01 * by6 + P02 * bz6
        fy6 += P10 * bx6 + P11 * by6 + P12 * bz6
        fz6 += P20 * bx6 + P21 * by6 + P22 * bz6
        fx7 += P00 * bx7 + P01 * by7 + P02 * bz7
        fy7 += P10 * bx7 + P11 * by7 + P12 * bz7
        fz7 += P20 * bx7 + P21 * by7 + P22 * bz7
    fx0 = 0.0; fy0 = 0.0; fz0 = 0.0
    gx = c * fx1 - sn * fy1; gy = sn * fx1 + c * fy1
    f[n1, 0] -= gx; f[n1, 1] -= gy; f[n1, 2] -= fz1
    fx0 += gx; fy0 += gy; fz0 += fz1
    gx = c * fx2 - sn * fy2; gy = sn * fx2 + c * fy2
    f[n2, 0] -= gx; f[n2, 1] -= gy; f[n2, 2] -= fz2
    fx0 += gx; fy0 += gy; fz0 += fz2
    gx = c * fx3 - sn * fy3; gy = sn * fx3 + c * fy3
    f[n3, 0] -= gx; f[n3, 1] -= gy; f[n3, 2] -= fz3
    fx0 += gx; fy0 += gy; fz0 += fz3
    gx = c * fx4 - sn * fy4; gy = sn * fx4 + c * fy4
    f[n4, 0] -= gx; f[n4, 1] -= gy; f[n4, 2] -= fz4
    fx0 += gx; fy0 += gy; fz0 += fz4
    gx = c * fx5 - sn * fy5; gy = sn * fx5 + c * fy5
    f[n5, 0] -= gx; f[n5, 1] -= gy; f[n5, 2] -= fz5
    fx0 += gx; fy0 += gy; fz0 += fz5
    gx = c * fx6 - sn * fy6; gy = sn * fx6 + c * fy6
    f[n6, 0] -= gx; f[n6, 1] -= gy; f[n6, 2] -= fz6
    fx0 += gx; fy0 += gy; fz0 += fz6
    gx = c * fx7 - sn * fy7; gy = sn * fx7 + c * fy7
    f[n7, 0] -= gx; f[n7, 1] -= gy; f[n7, 2] -= fz7
    fx0 += gx; fy0 += gy; fz0 += fz7
    f[n0, 0] += fx0; f[n0, 1] += fy0; f[n0, 2] += fz0
    return wint
