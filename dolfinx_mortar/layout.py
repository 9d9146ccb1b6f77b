"""The ONE definition of the packed facet data that the search, the packer and the kernels share.

A contact surface on one rank is a :class:`FacetArrays`: ``nf`` facets of one
facet type with ``nn`` geometry nodes each, numbered in basix's Lagrange order
for the facet cell (see :mod:`dolfinx_mortar.kernels.shape`), in ``d``
dimensions:

===============  ==================  =========================================
field            shape, dtype        meaning
===============  ==================  =========================================
``blocks``       (nf, nn) int64      global block (= node) index of each node
``dofs``         (nf, nn*d) int64    global PETSc dof of each node component,
                                     ``-1`` where a Dirichlet condition holds
``X``            (nf, nn, d) f8      reference coordinates relative to the
                                     contact pair's origin o (X − o; o = 0
                                     near the origin: surface.pair_origin)
``sign``         (nf,) f8            ±1 making the kernel normal outward
``owner``        (nf,) int32         rank whose cells hold the facet
===============  ==================  =========================================

Dof ordering inside a facet block is node-major: dof ``a*d + c`` is component
``c`` of node ``a``. Packed messages between ranks carry the same fields, one
facet per row, in :func:`pack` / :func:`unpack` order, so no offset is ever
computed elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class FacetArrays:
    """Facets of one contact surface known on this rank (see module docstring for shapes)."""

    ftype: int
    gdim: int
    blocks: np.ndarray
    dofs: np.ndarray
    X: np.ndarray
    sign: np.ndarray
    owner: np.ndarray

    @property
    def num_facets(self) -> int:
        return self.blocks.shape[0]

    @property
    def nodes_per_facet(self) -> int:
        return self.blocks.shape[1]

    @classmethod
    def empty(cls, ftype: int, nn: int, gdim: int) -> FacetArrays:
        return cls(
            ftype,
            gdim,
            np.empty((0, nn), np.int64),
            np.empty((0, nn * gdim), np.int64),
            np.empty((0, nn, gdim)),
            np.empty(0),
            np.empty(0, np.int32),
        )

    def take(self, idx) -> FacetArrays:
        """The facets ``idx`` (a new FacetArrays)."""
        return FacetArrays(
            self.ftype,
            self.gdim,
            self.blocks[idx],
            self.dofs[idx],
            self.X[idx],
            self.sign[idx],
            self.owner[idx],
        )

    @staticmethod
    def concatenate(parts: list[FacetArrays]) -> FacetArrays:
        p0 = parts[0]
        return FacetArrays(
            p0.ftype,
            p0.gdim,
            np.concatenate([p.blocks for p in parts]),
            np.concatenate([p.dofs for p in parts]),
            np.concatenate([p.X for p in parts]),
            np.concatenate([p.sign for p in parts]),
            np.concatenate([p.owner for p in parts]),
        )


def record_width(nn: int, gdim: int) -> int:
    """Number of float64 words of one packed facet: blocks, dofs, X, sign, owner."""
    return nn + nn * gdim + nn * gdim + 2


def pack(f: FacetArrays) -> np.ndarray:
    """Facets as rows of float64 (integers < 2**53 are exact), shape (nf, record_width)."""
    nf, nn, d = f.num_facets, f.nodes_per_facet, f.gdim
    out = np.empty((nf, record_width(nn, d)))
    o = 0
    out[:, o : o + nn] = f.blocks
    o += nn
    out[:, o : o + nn * d] = f.dofs
    o += nn * d
    out[:, o : o + nn * d] = f.X.reshape(nf, nn * d)
    o += nn * d
    out[:, o] = f.sign
    out[:, o + 1] = f.owner
    return out


def unpack(rows: np.ndarray, ftype: int, nn: int, gdim: int) -> FacetArrays:
    """Inverse of :func:`pack`."""
    rows = rows.reshape(-1, record_width(nn, gdim))
    nf, d = rows.shape[0], gdim
    o = 0
    blocks = rows[:, o : o + nn].astype(np.int64)
    o += nn
    dofs = rows[:, o : o + nn * d].astype(np.int64)
    o += nn * d
    X = rows[:, o : o + nn * d].reshape(nf, nn, d).copy()
    o += nn * d
    return FacetArrays(
        ftype, gdim, blocks, dofs, X, rows[:, o].copy(), rows[:, o + 1].astype(np.int32)
    )
