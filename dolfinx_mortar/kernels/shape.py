"""Lagrange shape functions of contact facets (numba kernels).

Facet types
-----------
Facets are identified by integer codes (module constants, usable inside numba code):

========== ==== ============================== ======= =====
name       code reference domain               nodes   tdim
========== ==== ============================== ======= =====
INTERVAL1  0    [0, 1]                         2       1
INTERVAL2  1    [0, 1]                         3       1
TRIANGLE1  2    {xi1, xi2 >= 0, xi1+xi2 <= 1}  3       2
TRIANGLE2  3    {xi1, xi2 >= 0, xi1+xi2 <= 1}  6       2
QUAD1      4    [0, 1]^2                       4       2
QUAD2      5    [0, 1]^2                       9       2
========== ==== ============================== ======= =====

Node ordering is basix's (equispaced) Lagrange ordering, i.e. the ordering of the
facet's geometry dofs in dolfinx:

* interval P1: xi = 0, 1; P2 adds 0.5;
* triangle P1: (0,0), (1,0), (0,1); P2 adds the edge midpoints in basix edge order
  (0.5,0.5), (0,0.5), (0.5,0);
* quadrilateral Q1: (0,0), (1,0), (0,1), (1,1); Q2 adds the edge midpoints
  (0.5,0), (0,0.5), (1,0.5), (0.5,1) and then the centre (0.5,0.5).

``REFERENCE_NODES[ftype]`` holds these coordinates (NumPy array, shape (n, tdim)).

Array conventions of :func:`shape`: ``xi`` (k,), ``N`` (n,), ``dN`` (n, k) with
``dN[a, alpha] = dN_a / dxi_alpha`` and ``ddN`` (n, k, k) with
``ddN[a, alpha, beta] = d2N_a / dxi_alpha dxi_beta``; k = tdim(ftype). The output
arrays may be larger than required; only the leading n (x k x k) block is written.
"""

import numpy as np

from ._numba import numba

INTERVAL1 = 0
INTERVAL2 = 1
TRIANGLE1 = 2
TRIANGLE2 = 3
QUAD1 = 4
QUAD2 = 5

#: All facet type codes.
FACET_TYPES = (INTERVAL1, INTERVAL2, TRIANGLE1, TRIANGLE2, QUAD1, QUAD2)
#: Human readable names, indexed by facet type code.
FACET_TYPE_NAMES = ("interval1", "interval2", "triangle1", "triangle2", "quad1", "quad2")
#: Largest number of nodes of a facet (QUAD2).
MAX_NODES = 9

_NUM_NODES = np.array([2, 3, 3, 6, 4, 9], dtype=np.int64)
_TDIM = np.array([1, 1, 2, 2, 2, 2], dtype=np.int64)

# Tensor-product indices (ix, iy) of the 1D Lagrange functions making up each quad node
# (1D index 0 <-> x = 0, 1 <-> x = 1, 2 <-> x = 0.5), in basix node order.
_Q1_IJ = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=np.int64)
_Q2_IJ = np.array(
    [[0, 0], [1, 0], [0, 1], [1, 1], [2, 0], [0, 2], [1, 2], [2, 1], [2, 2]], dtype=np.int64
)

#: Reference node coordinates (basix order), indexed by facet type code; shape (n, tdim).
REFERENCE_NODES = (
    np.array([[0.0], [1.0]]),
    np.array([[0.0], [1.0], [0.5]]),
    np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
    np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.5], [0.0, 0.5], [0.5, 0.0]]),
    np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]),
    np.array(
        [
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0],
            [0.5, 0.0],
            [0.0, 0.5],
            [1.0, 0.5],
            [0.5, 1.0],
            [0.5, 0.5],
        ]
    ),
)


@numba.njit(cache=True)
def num_nodes(ftype):
    """Number of nodes n of facet type ``ftype``."""
    if ftype < 0 or ftype > 5:
        raise ValueError("unknown facet type")
    return _NUM_NODES[ftype]


@numba.njit(cache=True)
def tdim(ftype):
    """Topological dimension k (1 for intervals, 2 for triangles and quadrilaterals)."""
    if ftype < 0 or ftype > 5:
        raise ValueError("unknown facet type")
    return _TDIM[ftype]


@numba.njit(cache=True)
def reference_centre(ftype, xi):
    """Write the centre of the reference facet into ``xi`` (k,): 1/2, (1/3, 1/3) or (1/2, 1/2)."""
    if ftype == INTERVAL1 or ftype == INTERVAL2:
        xi[0] = 0.5
    elif ftype == TRIANGLE1 or ftype == TRIANGLE2:
        xi[0] = 1.0 / 3.0
        xi[1] = 1.0 / 3.0
    else:
        xi[0] = 0.5
        xi[1] = 0.5


@numba.njit(cache=True)
def _lagrange_1d(degree, i, x):
    """1D Lagrange function i (nodes 0, 1[, 0.5]) of the given degree: (phi, phi', phi'')."""
    if degree == 1:
        if i == 0:
            return 1.0 - x, -1.0, 0.0
        return x, 1.0, 0.0
    if i == 0:
        return (1.0 - x) * (1.0 - 2.0 * x), 4.0 * x - 3.0, 4.0
    if i == 1:
        return x * (2.0 * x - 1.0), 4.0 * x - 1.0, 4.0
    return 4.0 * x * (1.0 - x), 4.0 - 8.0 * x, -8.0


@numba.njit(cache=True)
def shape(ftype, xi, N, dN, ddN):
    """Evaluate shape functions and their first and second derivatives at ``xi``.

    Parameters
    ----------
    ftype : int
        Facet type code.
    xi : float64 array (k,)
        Reference coordinates (may lie outside the reference domain: the polynomials
        are simply extrapolated).
    N : float64 array (n,)
        Output, ``N[a] = N_a(xi)``.
    dN : float64 array (n, k)
        Output, ``dN[a, alpha] = dN_a/dxi_alpha``.
    ddN : float64 array (n, k, k)
        Output, ``ddN[a, alpha, beta] = d2N_a/dxi_alpha dxi_beta`` (symmetric).
    """
    if ftype == INTERVAL1 or ftype == INTERVAL2:
        deg = 1 if ftype == INTERVAL1 else 2
        for a in range(deg + 1):
            f, df, ddf = _lagrange_1d(deg, a, xi[0])
            N[a] = f
            dN[a, 0] = df
            ddN[a, 0, 0] = ddf
    elif ftype == TRIANGLE1:
        x = xi[0]
        y = xi[1]
        N[0] = 1.0 - x - y
        N[1] = x
        N[2] = y
        dN[0, 0] = -1.0
        dN[0, 1] = -1.0
        dN[1, 0] = 1.0
        dN[1, 1] = 0.0
        dN[2, 0] = 0.0
        dN[2, 1] = 1.0
        for a in range(3):
            for al in range(2):
                for be in range(2):
                    ddN[a, al, be] = 0.0
    elif ftype == TRIANGLE2:
        x = xi[0]
        y = xi[1]
        L0 = 1.0 - x - y
        N[0] = L0 * (2.0 * L0 - 1.0)
        N[1] = x * (2.0 * x - 1.0)
        N[2] = y * (2.0 * y - 1.0)
        N[3] = 4.0 * x * y
        N[4] = 4.0 * L0 * y
        N[5] = 4.0 * L0 * x
        d0 = 1.0 - 4.0 * L0
        dN[0, 0] = d0
        dN[0, 1] = d0
        dN[1, 0] = 4.0 * x - 1.0
        dN[1, 1] = 0.0
        dN[2, 0] = 0.0
        dN[2, 1] = 4.0 * y - 1.0
        dN[3, 0] = 4.0 * y
        dN[3, 1] = 4.0 * x
        dN[4, 0] = -4.0 * y
        dN[4, 1] = 4.0 * L0 - 4.0 * y
        dN[5, 0] = 4.0 * L0 - 4.0 * x
        dN[5, 1] = -4.0 * x
        # second derivatives (constant)
        ddN[0, 0, 0] = 4.0
        ddN[0, 0, 1] = 4.0
        ddN[0, 1, 1] = 4.0
        ddN[1, 0, 0] = 4.0
        ddN[1, 0, 1] = 0.0
        ddN[1, 1, 1] = 0.0
        ddN[2, 0, 0] = 0.0
        ddN[2, 0, 1] = 0.0
        ddN[2, 1, 1] = 4.0
        ddN[3, 0, 0] = 0.0
        ddN[3, 0, 1] = 4.0
        ddN[3, 1, 1] = 0.0
        ddN[4, 0, 0] = 0.0
        ddN[4, 0, 1] = -4.0
        ddN[4, 1, 1] = -8.0
        ddN[5, 0, 0] = -8.0
        ddN[5, 0, 1] = -4.0
        ddN[5, 1, 1] = 0.0
        for a in range(6):
            ddN[a, 1, 0] = ddN[a, 0, 1]
    elif ftype == QUAD1 or ftype == QUAD2:
        if ftype == QUAD1:
            deg = 1
            ij = _Q1_IJ
        else:
            deg = 2
            ij = _Q2_IJ
        for a in range(ij.shape[0]):
            fx, dfx, ddfx = _lagrange_1d(deg, ij[a, 0], xi[0])
            fy, dfy, ddfy = _lagrange_1d(deg, ij[a, 1], xi[1])
            N[a] = fx * fy
            dN[a, 0] = dfx * fy
            dN[a, 1] = fx * dfy
            ddN[a, 0, 0] = ddfx * fy
            ddN[a, 0, 1] = dfx * dfy
            ddN[a, 1, 0] = dfx * dfy
            ddN[a, 1, 1] = fx * ddfy
    else:
        raise ValueError("unknown facet type")


@numba.njit(cache=True)
def inside(ftype, xi, tol):
    """True when ``xi`` (k,) lies in the reference facet enlarged by ``tol`` (reference units).

    Interval: -tol <= xi <= 1 + tol; triangle: xi1, xi2 >= -tol and xi1 + xi2 <= 1 + tol;
    quadrilateral: -tol <= xi1, xi2 <= 1 + tol. NaN coordinates are never inside.
    """
    if ftype == INTERVAL1 or ftype == INTERVAL2:
        return xi[0] >= -tol and xi[0] <= 1.0 + tol
    if ftype == TRIANGLE1 or ftype == TRIANGLE2:
        return xi[0] >= -tol and xi[1] >= -tol and xi[0] + xi[1] <= 1.0 + tol
    return xi[0] >= -tol and xi[0] <= 1.0 + tol and xi[1] >= -tol and xi[1] <= 1.0 + tol


@numba.njit(cache=True)
def _clip01(x):
    return min(max(x, 0.0), 1.0)


@numba.njit(cache=True)
def clamp_to_reference(ftype, xi):
    """Replace ``xi`` (k,) in place by the closest point (Euclidean in reference
    coordinates) of the reference facet. Points inside are left unchanged."""
    if ftype == INTERVAL1 or ftype == INTERVAL2:
        xi[0] = _clip01(xi[0])
    elif ftype == TRIANGLE1 or ftype == TRIANGLE2:
        x = xi[0]
        y = xi[1]
        if x >= 0.0 and y >= 0.0 and x + y <= 1.0:
            return
        # candidate on each edge, keep the nearest
        bx = _clip01(x)  # edge y = 0
        by = 0.0
        best = (bx - x) ** 2 + y**2
        cy = _clip01(y)  # edge x = 0
        dist = x**2 + (cy - y) ** 2
        if dist < best:
            best = dist
            bx = 0.0
            by = cy
        t = _clip01(0.5 * (x - y + 1.0))  # edge x + y = 1, point (t, 1 - t)
        dist = (t - x) ** 2 + (1.0 - t - y) ** 2
        if dist < best:
            bx = t
            by = 1.0 - t
        xi[0] = bx
        xi[1] = by
    else:
        xi[0] = _clip01(xi[0])
        xi[1] = _clip01(xi[1])
