"""The FE's edge reading against a brute-force second method: the loads at which nodes close,
found by solving the model again and again (bisection on the number of closed nodes)."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.fem import ContactOptions, Film, get_model
from filmcal.fem.model import FILM_EDGE_LEAD_PER_MM, NODE_CLOSING_LEAD


def _closing_load(model, film, options, n_closed: int, lo: float, hi: float, steps: int) -> float:
    """The force at which the contact grows from n_closed to n_closed + 1 nodes, by bisection."""
    def count(f):
        return model.solve(film, f, options).n_active
    assert count(lo) <= n_closed < count(hi)
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if count(mid) <= n_closed else (lo, mid)
    return 0.5 * (lo + hi)


def _brute_force_edge(model, film, force_n, options, steps):
    res = model.solve(film, force_n, options)
    k = res.n_active - 1  # the last closed node (the closed set is contiguous from the axis)
    r = model.r_face_mm
    f_k = _closing_load(model, film, options, k, 0.85 * force_n, force_n, steps)
    f_k1 = _closing_load(model, film, options, k + 1, force_n, 1.15 * force_n, steps)
    s = (force_n - f_k) / (f_k1 - f_k)
    h = r[k + 1] - r[k]
    lead = NODE_CLOSING_LEAD * h + (FILM_EDGE_LEAD_PER_MM * h * h if film is not None else 0.0)
    return res.contact_radius_mm, float(np.cbrt(r[k] ** 3 + s * (r[k + 1] ** 3 - r[k] ** 3))) - lead


@pytest.mark.parametrize("film", [None, Film(2800.0, 0.33), Film(900.0, 0.44)], ids=["no film", "HS-like", "soft, nu 0.44"])
def test_closing_load_edge_matches_solving_again(film):
    """The edge read from one solve (load rates with the statuses held) equals the edge from the
    closing loads found by re-solving: the affine-in-force argument holds."""
    got, expected = _brute_force_edge(get_model(450.0), film, 61e3, ContactOptions(), steps=18)
    assert got == pytest.approx(expected, abs=2e-5)


def test_closing_load_edge_of_the_large_strain_film_matches_solving_again():
    """For the large-strain film the load rates are its tangent's: still within 0.5 um of re-solving."""
    got, expected = _brute_force_edge(get_model(450.0), Film(900.0, 0.33), 61e3,
                                      ContactOptions(kinematics="large"), steps=12)
    assert got == pytest.approx(expected, abs=5e-4)
