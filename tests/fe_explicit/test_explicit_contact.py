"""Node-to-segment penalty contact: bar impact (2D and 3D) and Coulomb friction on a sliding block.

References:
* Longitudinal impact of two identical elastic bars (St Venant / 1D wave theory; Graff, Wave Motion
  in Elastic Solids, sec. 2.4; Johnson, Contact Mechanics, sec. 11.3): contact lasts 2 L / c, the
  striker stops and the struck bar leaves with the impact speed. The penalty spring (scale 0.3, a
  third of one element's axial stiffness) lengthens the contact by about 1.5 %, so the duration
  tolerance is 3 %; the final velocities are checked to 3 % of the impact speed, the energy
  balance to 0.2 %.
* A block sliding on a fixed base under a normal load P decelerates at mu P / M (Coulomb's law).
  The friction is regularized with v_reg = 1 mm/s at 1 m/s sliding speed (1e-6 effect); the normal
  contact force oscillates around P after the load ramp, so the mean deceleration over 6 ms is
  compared, tolerance 3 %.
"""
from __future__ import annotations

import numpy as np

from gearrom.fe.explicit import (ContactPair, ExplicitModel, Material, NodalLoad, boundary_segments,
                                 prepare, solve)
from gearrom.fe.explicit.meshes import box_hex8, rectangle_q4

MAT = Material(nu=0.0)
C_BAR = np.sqrt(MAT.E / MAT.rho)


def _two_bars(nodes, elements, gap, length):
    n = nodes.shape[0]
    nodes2 = nodes.copy()
    nodes2[:, 0] += length + gap
    allnodes = np.vstack([nodes, nodes2])
    allel = np.vstack([elements, elements + n])
    striker = np.arange(n)
    face = np.nonzero(np.abs(nodes[:, 0] - length) < 1e-12)[0]
    segs = boundary_segments(elements + n)
    xs = allnodes[segs].mean(axis=1)
    master = segs[np.abs(xs[:, 0] - (length + gap)) < 1e-12]
    return allnodes, allel, striker, face, master


def _bar_impact(nodes, elements, length, thickness):
    v0, gap = 1.0, 1e-5
    allnodes, allel, striker, face, master = _two_bars(nodes, elements, gap, length)
    vel = np.zeros_like(allnodes)
    vel[striker, 0] = v0
    model = ExplicitModel(allnodes, allel, MAT, thickness=thickness,
                          node_sets={"face": face}, surfaces={"struck": master},
                          contacts=(ContactPair("face", "struck", penalty_scale=0.3),),
                          initial_velocity=vel)
    n = nodes.shape[0]
    probes = np.arange(allnodes.shape[0])
    t_hit = gap / v0
    res = solve(model, t_hit + 3 * length / C_BAR, sample_period=length / C_BAR / 200, probes=probes)
    m = prepare(model)["mass"]
    v_str = (m[:n] * res.probe_v[:, :n, 0]).sum(1) / m[:n].sum()
    v_hit = (m[n:] * res.probe_v[:, n:, 0]).sum(1) / m[n:].sum()
    in_contact = res.energy("contact") > 1e-6 * res.energy("kinetic")[0]
    duration = np.ptp(res.t[in_contact]) + (res.t[1] - res.t[0])
    return res, duration, v_str[-1], v_hit[-1]


def _block_on_base(base, base_el, p_total, vel_x, contact, **model_kw):
    """A Q4 block (0.02 x 0.01 m) 1 um above a fixed base, sliding at ``vel_x`` and pressed by ``p_total``
    (ramped over 1 ms) on its top: (model, block node ids)."""
    blk, blk_el = rectangle_q4(0.02, 0.01, 8, 4, y0=1e-6)
    nb = base.shape[0]
    nodes = np.vstack([base, blk])
    elements = np.vstack([base_el, blk_el + nb])
    segs = boundary_segments(base_el)
    master = segs[np.abs(base[segs].mean(axis=1)[:, 1]) < 1e-12]
    bottom = nb + np.nonzero(blk[:, 1] < 2e-6)[0]
    top = nb + np.nonzero(blk[:, 1] > 0.01)[0]
    block = nb + np.arange(blk.shape[0])
    vel = np.zeros_like(nodes)
    vel[block, 0] = vel_x
    load = NodalLoad("top", (0.0, -p_total / top.size), times=(0.0, 1e-3), factors=(0.0, 1.0))
    model = ExplicitModel(nodes, elements, model_kw.pop("mat", Material()), thickness=0.01,
                          node_sets={"base": np.arange(nb), "bottom": bottom, "top": top},
                          surfaces={"base_top": master}, fixed={"base": (0, 1)}, loads=(load,),
                          contacts=(contact,), initial_velocity=vel, **model_kw)
    return model, block


def test_bar_impact_q4():
    length = 0.1
    nodes, elements = rectangle_q4(length, 0.01, 100, 2)
    res, duration, v1, v2 = _bar_impact(nodes, elements, length, 0.01)
    assert abs(duration / (2 * length / C_BAR) - 1) < 0.03, duration / (2 * length / C_BAR)
    assert abs(v1) < 0.03 and abs(v2 - 1.0) < 0.03, (v1, v2)
    assert res.energy_error < 2e-3


def test_bar_impact_hex8():
    length = 0.06
    nodes, elements = box_hex8(length, 0.006, 0.006, 60, 2, 2)
    res, duration, v1, v2 = _bar_impact(nodes, elements, length, 1.0)
    assert abs(duration / (2 * length / C_BAR) - 1) < 0.03, duration / (2 * length / C_BAR)
    assert abs(v1) < 0.03 and abs(v2 - 1.0) < 0.03, (v1, v2)
    assert res.energy_error < 2e-3


def test_coulomb_friction_deceleration():
    mu, v0, p_total = 0.1, 1.0, 20.0
    base, base_el = rectangle_q4(0.2, 0.01, 40, 2, x0=-0.05, y0=-0.01)
    model, block = _block_on_base(base, base_el, p_total, v0, ContactPair("bottom", "base_top", mu=mu, penalty_scale=1.0),
                                  hourglass_viscosity=0.05)
    res = solve(model, 8e-3, sample_period=5e-5, probes=block)
    mass = prepare(model)["mass"][block]
    vx = (mass * res.probe_v[:, :, 0]).sum(1) / mass.sum()
    sel = (res.t >= 2e-3) & (res.t <= 8e-3)
    decel = -np.polyfit(res.t[sel], vx[sel], 1)[0]
    expected = mu * p_total / mass.sum()
    assert abs(decel / expected - 1) < 0.03, (decel, expected)
    assert res.energy("friction")[-1] > 0
    assert res.energy_error < 5e-3


def test_sliding_across_unequal_segments_conserves_energy():
    """Frictionless block pressed onto a base whose top edges alternate between two lengths (1:3) and
    sliding across them: the penalty energy must stay continuous as nodes pass from one segment to the
    next (a penalty per segment, k ~ A^2 / V, would create or destroy (k2 - k1) g^2 / 2 at each
    passage). Reference: energy conservation of the frictionless system; the balance error must stay
    below 1 % of the peak contact energy (the ROM-vs-FE reference gate)."""
    base, base_el = rectangle_q4(0.2, 0.01, 40, 2, x0=-0.05, y0=-0.01)
    xs = np.unique(base[:, 0])
    widths = np.where(np.arange(xs.size - 1) % 2 == 0, 1.0, 3.0)
    new_x = -0.05 + np.concatenate([[0.0], np.cumsum(widths)]) / widths.sum() * 0.2
    base[:, 0] = np.interp(base[:, 0], xs, new_x)
    model, _ = _block_on_base(base, base_el, 2.0e4, 1.0, ContactPair("bottom", "base_top", penalty_scale=0.3),
                              integration="full")
    res = solve(model, 8e-3, sample_period=2e-5)
    peak = res.energy("contact").max()
    assert peak > 0
    assert np.abs(res.energy("balance_error")).max() < 0.01 * peak, (np.abs(res.energy("balance_error")).max(), peak)
