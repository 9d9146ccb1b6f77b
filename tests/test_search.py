"""Candidate search: the master facets whose bounding boxes meet each slave facet's."""

import numpy as np
import pytest
from mpi4py import MPI

from dolfinx_mortar.kernels.shape import INTERVAL1
from dolfinx_mortar.layout import FacetArrays
from dolfinx_mortar.search import candidates, exchange_master_facets


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


def test_the_exchange_covers_each_configuration_it_is_given():
    """``exchange_master_facets`` with two configurations (friction: the current one and
    the start of the step): a master facet is sent when, in SOME configuration, its box
    inflated by the margin meets the slave box of that configuration; facets between the
    two positions (the path of a slide) are not. One configuration: as before."""
    comm = MPI.COMM_SELF
    n = 40  # master segments [i, i+1] × {0} along x ∈ [0, 40]
    x0 = np.arange(n, dtype=float)
    X = np.zeros((n, 2, 2))
    X[:, 0, 0], X[:, 1, 0] = x0, x0 + 1.0
    blocks = np.stack([np.arange(n), np.arange(n) + 1], axis=1)
    dofs = np.repeat(2 * blocks, 2, axis=1) + np.tile([0, 1], 2)
    master = FacetArrays(INTERVAL1, 2, blocks, dofs, X, np.ones(n), np.zeros(n, np.int32))
    # the slave: [2, 4] at the start of the step, slid by 20 to [22, 24] now
    xs_n = np.array([[[2.0, 0.1], [4.0, 0.1]]])
    xs = xs_n + [20.0, 0.0]

    def sent(xm, xsl, margin=0.5):
        return sorted(exchange_master_facets(comm, master, xm, xsl, margin).blocks[:, 0])

    assert sent(X, xs) == [21, 22, 23, 24]  # the current configuration only
    assert sent([X, X], [xs, xs_n]) == [1, 2, 3, 4, 21, 22, 23, 24]
    # the master slid instead (by -20): its start-of-step facets under the slave
    Xm = X - [20.0, 0.0]
    assert sent([Xm, X], [xs_n, xs_n]) == [1, 2, 3, 4, 21, 22, 23, 24]
    # a rank without slave facets receives none
    assert sent([X, X], [np.empty((0, 2, 2)), np.empty((0, 2, 2))]) == []
