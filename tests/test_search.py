"""Candidate search: the master facets whose bounding boxes meet each slave facet's."""

import numpy as np
import pytest

from dolfinx_mortar.search import candidates


def _brute_force(xs, xm, reach):
    slo, shi = xs.min(axis=1) - reach[:, None], xs.max(axis=1) + reach[:, None]
    mlo, mhi = xm.min(axis=1), xm.max(axis=1)
    hit = np.all((mhi[None] >= slo[:, None]) & (mlo[None] <= shi[:, None]), axis=2)
    return [np.flatnonzero(row) for row in hit]


@pytest.mark.parametrize("d", [2, 3])
def test_candidates_are_the_overlapping_boxes(d):
    """Random facets of graded sizes (a factor 100: the sweep's window is as wide as the
    largest master box), reach up to a facet size: the CSR result is exactly the set of
    master facets whose box meets the slave facet's inflated box, sorted per slave
    facet."""
    rng = np.random.default_rng(7)
    k = d  # nodes per facet (segments in 2D, triangles in 3D)

    def facets(n):
        size = 10.0 ** rng.uniform(-2, 0, n)
        centre = rng.uniform(0, 3, (n, d))
        return centre[:, None, :] + size[:, None, None] * rng.normal(size=(n, k, d))

    xs, xm = facets(150), facets(400)
    reach = rng.uniform(0, 0.3, 150)
    off, idx = candidates(xs, xm, reach)
    ref = _brute_force(xs, xm, reach)
    assert off[0] == 0 and off[-1] == idx.size
    assert sum(r.size for r in ref) > 150  # the test sees real overlaps
    for f, r in enumerate(ref):
        np.testing.assert_array_equal(idx[off[f] : off[f + 1]], r)


def test_no_facets():
    """Empty surfaces give empty CSRs; a box with a NaN coordinate meets none."""
    nan = np.zeros((2, 2, 2))
    nan[0, 0, 0] = np.nan
    off, idx = candidates(nan, np.zeros((3, 2, 2)), np.zeros(2))
    assert off.tolist() == [0, 0, 3] and idx.tolist() == [0, 1, 2]
    off, idx = candidates(np.empty((0, 2, 2)), np.zeros((3, 2, 2)), np.empty(0))
    assert off.tolist() == [0] and idx.size == 0
    off, idx = candidates(np.zeros((2, 2, 2)), np.empty((0, 2, 2)), np.zeros(2))
    assert off.tolist() == [0, 0, 0] and idx.size == 0
