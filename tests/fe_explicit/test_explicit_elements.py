"""Element types of the explicit solver: lookup, and the precomputation against the exact volume of a box."""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.errors import ConfigError
from gearrom.fe.explicit import kernels
from gearrom.fe.explicit.elements import ELEMENT_TYPES, element_type
from gearrom.fe.explicit.meshes import box_hex8


def test_lookup_and_unknown_type():
    assert element_type(3, 8, "full").kernel is kernels.hex8_full_element
    assert element_type(2, 4, "reduced").name == "Q4"
    with pytest.raises(ConfigError, match="no explicit element for 2D elements of 3 nodes.*known: Q4"):
        element_type(2, 3, "reduced")
    assert len(ELEMENT_TYPES) == 4


@pytest.mark.parametrize("integration", ["reduced", "full"])
def test_hex8_box_volume_mass_and_hourglass(integration):
    """A 2 x 3 x 4 mm box in 2 x 2 x 2 elements: volumes and row-sum masses add up to the box volume exactly;
    fully integrated elements carry no hourglass coefficients and their Gauss weights add up to the volume."""
    nodes, conn = box_hex8(2e-3, 3e-3, 4e-3, 2, 2, 2)
    el = element_type(3, 8, integration).precompute(nodes, conn, 1.0, 1e11, 8e10, 7850.0, 0.05, 0.0)
    vol = 2e-3 * 3e-3 * 4e-3
    assert el.V0.sum() == pytest.approx(vol, rel=1e-12) and el.me.sum() == pytest.approx(vol, rel=1e-12)
    assert np.all(el.lam_max > 0)
    if integration == "full":
        assert el.full and not el.khg.any() and el.Wg.sum() == pytest.approx(vol, rel=1e-12)
    else:
        assert not el.full and np.all(el.khg > 0)


@pytest.mark.parametrize("n_parts", [1, 2, 3])
def test_element_schedule_is_race_free_and_complete(n_parts):
    """The loop's element schedule (geometry.schedule_elements) on a shuffled box: every element once, and no two
    blocks of one pass share a node (the condition for scattering their forces in parallel without a race);
    each part holds elements, and with more than one part some elements straddle two parts' nodes."""
    from gearrom.fe.explicit.geometry import schedule_elements

    nodes, conn = box_hex8(0.01, 0.006, 0.005, 10, 6, 5)
    conn = conn[np.random.default_rng(1).permutation(conn.shape[0])]
    order, bptr, cptr = schedule_elements(conn, nodes.shape[0], n_parts, block=16)
    assert np.array_equal(np.sort(order), np.arange(conn.shape[0]))
    assert bptr[0] == 0 and bptr[-1] == conn.shape[0] and np.all(np.diff(bptr) >= 0)
    assert cptr[1] == n_parts and cptr[-1] == bptr.size - 1
    ordered = conn[order]
    for c in range(cptr.size - 1):
        owner = {}
        for b in range(cptr[c], cptr[c + 1]):
            for node in np.unique(ordered[bptr[b]:bptr[b + 1]]):
                assert owner.setdefault(int(node), b) == b, f"pass {c}: node {node} in blocks {owner[node]} and {b}"
    assert np.all(np.diff(bptr[:n_parts + 1]) > 0)
    assert (bptr[-1] == bptr[n_parts]) == (n_parts == 1)
