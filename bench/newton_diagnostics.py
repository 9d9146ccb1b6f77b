"""Is the Newton of a demo scene quadratic? Checks at the iterates of one step's main solve.

For the hertz2d demo scene (``--integration``, ``--recovery``), the load step ``--step``
(1-based, default the last) is watched: at each Jacobian evaluation of its first Newton
solve (the main one; the later Uzawa rounds start near the solution) this prints

- ``|R|``: the residual norm at the iterate u, and ``|du|``: the Newton step
  du = K⁻¹R (MUMPS);
- ``fd``: ‖K du − (R(u + h du) − R(u − h du))/2h‖ / ‖…‖ with h = 1e-4 (relative to
  ‖du‖ = 1). The check is along the Newton step, so Dirichlet dofs do not move (a random
  direction would perturb them, and K does not see that);
- ``quad``: ‖R(u − t du) − (1 − t) R(u)‖ / t² for t = 1/4, 1/2, 1. For a smooth residual
  and an exact tangent this is constant: the remainder of the Newton step is quadratic
  in t. It is the residual the full step leaves.

Run (serial)::

    /usr/bin/python3 bench/newton_diagnostics.py [--step 4] [--integration segment] [--tri]

An iterate that the l2 line search placed on a kink of the residual (an active-set or
pairing switch; the search minimises ‖R‖ along the step, and minima sit at kinks) shows a
large ``fd`` and a ``quad`` that is not constant: the residual is not differentiable
there, and the check says nothing about the tangent.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))

import demo_hertz2d  # noqa: E402
from dolfinx.fem.petsc import create_vector  # noqa: E402

from dolfinx_mortar import solver as solver_module  # noqa: E402
from dolfinx_mortar.runner import run  # noqa: E402
from dolfinx_mortar.scene import parse_scene  # noqa: E402


def _residual(problem, x):
    b = create_vector(problem.F_form)
    problem.update_contact(x)
    problem.residual(x, b)
    return b


def check(problem, log) -> None:
    """The checks at the problem's current state (collective)."""
    u0 = problem.u.vector.copy()
    K = problem.create_matrix()
    r = _residual(problem, u0)
    problem.jacobian(u0, K)
    ksp = PETSc.KSP().create(problem.comm)
    ksp.setOperators(K)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    du = u0.copy()
    ksp.solve(r, du)
    h = 1e-4 / max(du.norm(), 1e-300)
    up, um = u0.copy(), u0.copy()
    up.axpy(h, du)
    um.axpy(-h, du)
    fd = _residual(problem, up)
    fd.axpy(-1.0, _residual(problem, um))
    fd.scale(0.5 / h)
    kdu = u0.copy()
    K.mult(du, kdu)
    kdu.axpy(-1.0, fd)
    quad = []
    for t in (0.25, 0.5, 1.0):
        ut = u0.copy()
        ut.axpy(-t, du)
        rt = _residual(problem, ut)
        rt.axpy(-(1.0 - t), r)
        quad.append(rt.norm() / t**2)
    log.append((r.norm(), du.norm(), kdu.norm() / fd.norm(), quad))
    problem.update_contact(u0)
    for v in (K, ksp, r, du, up, um, fd, kdu):
        v.destroy()


def main(argv=None) -> list:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--step", type=int, default=4, help="load step to watch (1-based) [4]")
    ap.add_argument("--integration", default="element", help="[element]")
    ap.add_argument("--recovery", default="lumped", help="[lumped]")
    ap.add_argument("--tri", action="store_true", help="the demo's --tri mesh (triangles)")
    ap.add_argument("--out", default="/tmp/newton_diagnostics", help="run directory")
    args = ap.parse_args(argv)
    box, log, state = {}, [], {"step": 0, "solve": 0}
    newton_cls = solver_module.NewtonSolver
    orig_j, orig_solve, orig_begin = newton_cls._J, newton_cls.solve, None

    def watched_j(self, snes, x, A, P):
        orig_j(self, snes, x, A, P)
        if state["step"] == args.step and state["solve"] == 1:
            self.problem.ensure_contact_at(x)
            check(self.problem, log)
            self.problem.ensure_contact_at(x)

    def counted_solve(self, *a, **k):
        state["solve"] += 1
        return orig_solve(self, *a, **k)

    def setup(problem):
        nonlocal orig_begin
        box["p"] = problem
        orig_begin = problem.begin_step

        def begin_step():
            state["step"] += 1
            state["solve"] = 0
            orig_begin()

        problem.begin_step = begin_step

    newton_cls._J, newton_cls.solve = watched_j, counted_solve
    try:
        sc = demo_hertz2d.scene(0, 1, args.integration, quads=not args.tri, recovery=args.recovery)
        run(parse_scene(sc, Path(".")), MPI.COMM_WORLD, Path(args.out), setup=setup)
    finally:
        newton_cls._J, newton_cls.solve = orig_j, orig_solve
    if MPI.COMM_WORLD.rank == 0:
        print(f"hertz2d {args.integration} {args.recovery}, step {args.step}, main solve:")
        print("  |R|        |du|       fd(K du)   quad t=1/4, 1/2, 1")
        for rn, dn, e, q in log:
            print(f"  {rn:.3e}  {dn:.3e}  {e:.1e}    " + ", ".join(f"{v:.4e}" for v in q))
        steps = [x[1] for x in log]
        if len(steps) >= 3:
            c = [steps[k + 1] / steps[k] ** 2 for k in range(len(steps) - 1)]
            print("  |du_k+1|/|du_k|^2:", ", ".join(f"{v:.3g}" for v in c))
    return log


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
