"""Conforming reference of the rounded flat punch (bench/flat_punch, docs/method-notes.md,
"Flat-punch edge"): the block alone, its top pushed down by d = 0.01 on |x| <= a (a
rigid frictionless flat punch of half-width a: u_y = -d there, u_x free), its bottom
clamped; P2 on a crossed structured mesh of nx x nx/2 squares, h = 10/nx. Prints the
stiffness F/d (F: the vertical force on the punched dofs) and the pressure at vertices
x = 0, 0.3, 0.5, 0.7, 0.8 (p = 3 R/h: a P2 vertex's reaction takes h/3 of a uniform p).
The true contact ends on the punch's rounded corners, between a = 0.9 (the flat part)
and 1.0, so a = 0.9 and a = 1.0 bound the stiffness. A session-54 probe's script
(/tmp/adv55/p1/ref.py), tidied.

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/flat_punch/reference.py 200 0.9 1.0
"""

import sys

import numpy as np
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import LinearProblem, assemble_vector
from mpi4py import MPI
from petsc4py import PETSc

W, H, E, NU, D = 10.0, 5.0, 1.0, 0.3, 0.01


def main(nx: int, halfwidths: list[float]) -> None:
    msh = mesh.create_rectangle(
        MPI.COMM_SELF,
        [np.array([-W / 2, -H]), np.array([W / 2, 0.0])],
        [nx, nx // 2],
        mesh.CellType.triangle,
        diagonal=mesh.DiagonalType.crossed,
    )
    V = fem.VectorFunctionSpace(msh, ("Lagrange", 2))
    mu, lam = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def sigma(w):
        eps = ufl.sym(ufl.grad(w))
        return 2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(2)

    a_form = ufl.inner(sigma(u), ufl.sym(ufl.grad(v))) * ufl.dx
    zero = fem.Constant(msh, (0.0, 0.0))
    L = ufl.inner(zero, v) * ufl.dx
    bottom = fem.locate_dofs_geometrical(V, lambda x: np.isclose(x[1], -H))
    Vy, _ = V.sub(1).collapse()
    coords = V.tabulate_dof_coordinates()
    h = W / nx
    for a in halfwidths:
        top = fem.locate_dofs_geometrical(
            (V.sub(1), Vy), lambda x, a=a: np.isclose(x[1], 0.0) & (np.abs(x[0]) <= a + 1e-10)
        )
        uy = fem.Function(Vy)
        uy.x.array[:] = -D
        bcs = [
            fem.dirichletbc(np.zeros(2, dtype=PETSc.ScalarType), bottom, V),
            fem.dirichletbc(uy, top, V.sub(1)),
        ]
        options = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
        uh = LinearProblem(a_form, L, bcs=bcs, petsc_options=options).solve()
        # the block's internal force at the punched dofs: the punch's force on the block
        reaction = assemble_vector(fem.form(ufl.inner(sigma(uh), ufl.sym(ufl.grad(v))) * ufl.dx))
        force = reaction.array[top[0]].sum()
        print(f"nx = {nx}, a = {a}: stiffness F/d = {-force / D:.5g}")
        for xq in (0.0, 0.3, 0.5, 0.7, 0.8):
            node = np.argmin(np.hypot(coords[:, 0] - xq, coords[:, 1]))
            print(f"    x = {coords[node, 0]:.4f}: p = {-3 * reaction.array[2 * node + 1] / h:.6g}")


if __name__ == "__main__":
    main(int(sys.argv[1]), [float(a) for a in sys.argv[2:]] or [0.9, 1.0])
