"""Drawing micro-geometry on the flanks of the explicit helical model.

The quasi-static LTCA takes profile and lead modifications as initial gaps on the transverse line of
action (:mod:`gearrom.fe.flankgaps`). The explicit model carries them in its geometry instead: after the
pair is placed on its perfect flanks (so that, as in the LTCA, the TE is measured from the perfect
gears' first contact), each node of the contact sets (the flanks between the root form circle and the
usable tip, both sides, as the drawing modifies both) is moved into the material by the gear's removal
at that point, along the transverse outline normal (on an involute that normal is the transverse line
of action, the direction the LTCA measures its gaps in):

    removal(L, z) = profile_removal(L) + lead_removal(z)

with ``L`` the node's roll length sqrt(r^2 - r_b^2) and ``z`` its axial position from the middle of the
face width. Flank nodes above the usable tip d_Na are in no contact set (the LTCA's active flank ends
there too) and keep the generated outline, as do the fillets and the tip.
"""
from __future__ import annotations

import numpy as np

from gearrom.fe.flankgaps import lead_removal, profile_removal

__all__ = ["apply_flank_modifications", "flank_normals", "micro_enabled", "modification_moves", "usable_tip_radius"]


def flank_normals(xy: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Outward unit normals (n, 2) at the nodes of the closed outline ``loop`` (node indices in order,
    counter-clockwise around the material) of a section ``xy``: the mean of the two adjoining segments'
    normals. Nodes not on the loop get zero."""
    p = xy[loop]
    seg = np.roll(p, -1, axis=0) - p
    nrm = np.column_stack([seg[:, 1], -seg[:, 0]])
    nrm /= np.maximum(np.hypot(*nrm.T), 1e-300)[:, None]
    avg = nrm + np.roll(nrm, 1, axis=0)
    avg /= np.maximum(np.hypot(*avg.T), 1e-300)[:, None]
    out = np.zeros_like(xy)
    out[loop] = avg
    return out


def modification_moves(pair, i: int, xy: np.ndarray, centre, z: float, normals: np.ndarray,
                       flank: np.ndarray) -> np.ndarray:
    """Transverse moves (len(flank), 2) of the flank nodes ``flank`` of gear ``i`` in one section.

    ``xy``: the section's node positions (m) with the gear centre at ``centre``; ``normals``: their
    outward outline normals (:func:`flank_normals`); ``z``: the section's axial position from the middle
    of the face width (m). Each node moves by its removal (m) against its outward normal.
    """
    r = np.hypot(*(xy[flank] - np.asarray(centre, float)).T)
    roll = np.sqrt(np.maximum(r ** 2 - pair.rb[i] ** 2, 0.0))
    removal = profile_removal(pair, i, roll) + float(lead_removal(pair, i, z))
    return -removal[:, None] * normals[flank]


def usable_tip_radius(pair, i: int) -> float:
    """Radius of the usable tip d_Na / 2 (the tip diameter when the micro-geometry is off) [m]."""
    return 0.5 * pair.effective_tip_diameter[i]


def micro_enabled(pair) -> bool:
    """Whether either gear's drawing micro-geometry is switched on."""
    return any(g.micro.enabled for g in pair.gears)


def apply_flank_modifications(pair, nodes: np.ndarray, base, z_gear, loops, flanks, centres) -> np.ndarray:
    """``nodes`` (3D, m) of an extruded helical pair with every contact-set node moved by its gear's removal.

    ``base``: per gear ``(first 2D node, end 2D node, first 3D node, layer count)`` (the extrusion's
    layout: each layer is a rigidly turned copy of the section); ``z_gear``: per gear the layer planes (m,
    from the middle of the face width); ``loops``: per gear the section outline in order (section-local
    node indices, either direction); ``flanks``: per gear the contact-set nodes (section-local);
    ``centres``: per gear the transverse centre (m).
    """
    out = np.array(nodes, float)
    for g in (0, 1):
        lo, hi, st, nl = base[g]
        m = hi - lo
        loop = np.asarray(loops[g], np.int64)
        flank = np.asarray(flanks[g], np.int64)
        for k in range(nl):
            xy = out[st + k * m: st + (k + 1) * m, :2]
            p = xy[loop]
            area = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
            normals = flank_normals(xy, loop if area > 0 else loop[::-1])
            xy[flank] += modification_moves(pair, g, xy, centres[g], float(z_gear[g][k]), normals, flank)
    return out
