"""Is the Newton of a demo scene quadratic? Checks at the iterates of one step's main solve.

For the hertz2d demo scene (``--integration``, ``--recovery``, ``--order``, ``--tri``), the
load step ``--step`` (1-based, default the last) is watched: at each Jacobian evaluation
of its first Newton solve (the main one; the later Uzawa rounds start near the solution;
``--solve N`` watches the N-th instead) this prints

- ``|R|``: the residual norm at the iterate u, and ``|du|``: the Newton step
  du = K⁻¹R (MUMPS);
- ``|du|_K``: the Newton step in the energy norm of the tangent, √(R·du) = √(duᵀ K du)
  (the Newton decrement: invariant under a change of the unknowns, so it does not weigh a
  stiff direction by its stiffness as ‖R‖ does, nor a soft one by its softness as ‖du‖
  does; K is symmetric positive definite here, frictionless);
- ``fd``: ‖K du − (R(u + h du) − R(u − h du))/2h‖ / ‖…‖ with h = 1e-4 (relative to
  ‖du‖ = 1; ``--fd-step``: a residual that has a kink within that distance of u reads
  far from 0 at a larger h and close to 0 at a smaller one). The check is along the Newton step, so Dirichlet dofs do not move (a random
  direction would perturb them, and K does not see that);
- ``quad``: ‖R(u − t du) − (1 − t) R(u)‖ / t² for t = 1/4, 1/2, 1. For a smooth residual
  and an exact tangent this is constant: the remainder of the Newton step is quadratic
  in t. It is the residual the full step leaves.

With ``--polish N`` it also takes N more exact Newton steps from the state where that
solve converged (on a copy: the run goes on from its own state) and prints the residual
norms they leave, the round-off plateau of ‖R‖ (next to the step's round-off level f
that ``ContactProblem.residual_round_off`` measures at the step's end: a Newton step
from a residual that is only rounding noise leaves the next noise plus the last one,
about √2 f), and the errors e_k = ‖u_k − u*‖ of the
solve's iterates against the polished state u*. The polished state is itself known only
to its round-off level s, the median ‖du‖ of the polish steps after the first (each
starts from a residual that is rounding noise), so the errors are read as the residual
norms are (``demos/_common.solve_order`` with s for f): the order of the last three above
FLOOR_FACTOR × s, or, when only the last lies below, the bound from e_n + 2 s
(BENCHMARKS §2, "Session 18"; §28). ``--polish`` needs 2 or more for s.

Run (serial)::

    /usr/bin/python3 bench/newton_diagnostics.py [--step 4] [--integration segment] [--tri]
    /usr/bin/python3 bench/newton_diagnostics.py --step 1 --polish 5
    /usr/bin/python3 bench/newton_diagnostics.py --order 2 --integration segment --step 4 --solve 2
    /usr/bin/python3 bench/newton_diagnostics.py --step 3 --fd-step 1e-3
    /usr/bin/python3 bench/newton_diagnostics.py --refine 1 --steps 8 --step 6 --polish 4

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

import _common as cm  # noqa: E402
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


def check(problem, log, fd_step: float = 1e-4) -> None:
    """The checks at the problem's current state (collective); ``fd_step``: the length of
    the central differences' perturbation along the Newton step."""
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
    h = fd_step / max(du.norm(), 1e-300)
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
    log.append((r.norm(), du.norm(), kdu.norm() / fd.norm(), quad, abs(r.dot(du)) ** 0.5))
    problem.update_contact(u0)
    for v in (K, ksp, r, du, up, um, fd, kdu):
        v.destroy()


def polish(problem, n: int) -> tuple[list[float], list[float], PETSc.Vec]:
    """n exact Newton steps (a new Jacobian and MUMPS factorization each) from the
    problem's current state, on a copy (collective). Returns the residual norm after each
    step, the length ‖du‖ of each step and the last iterate; the problem's contact state
    is restored."""
    u = problem.u.vector.copy()
    K = problem.create_matrix()
    ksp = PETSc.KSP().create(problem.comm)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    du = u.copy()
    norms, moves = [], []
    for _ in range(n):
        r = _residual(problem, u)
        K.zeroEntries()
        problem.jacobian(u, K)
        ksp.setOperators(K)
        ksp.solve(r, du)
        moves.append(du.norm())
        u.axpy(-1.0, du)
        r.destroy()
        r = _residual(problem, u)
        norms.append(r.norm())
        r.destroy()
    problem.update_contact(problem.u.vector)
    for v in (K, ksp, du):
        v.destroy()
    return norms, moves, u


def error_level(moves: list[float]) -> float:
    """The round-off level of the polished state: the median length of the polish steps
    after the first (the first removes the solve's last error; the later ones start from
    a residual that is rounding noise and move u by K⁻¹ of it). 0 with fewer than two."""
    return float(np.median(moves[1:])) if len(moves) >= 2 else 0.0


def main(argv=None) -> list:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--step", type=int, default=4, help="load step to watch (1-based) [4]")
    ap.add_argument("--integration", default="element", help="[element]")
    ap.add_argument("--recovery", default="lumped", help="[lumped]")
    ap.add_argument("--tri", action="store_true", help="the demo's --tri mesh (triangles)")
    ap.add_argument("--order", type=int, choices=(1, 2), default=1, help="element order [1]")
    ap.add_argument(
        "--solve", type=int, default=1, help="Newton solve of the step to watch (1-based) [1]"
    )
    ap.add_argument("--refine", type=int, choices=(0, 1, 2), default=0, help="mesh level [0]")
    ap.add_argument("--steps", type=int, default=4, help="load steps of the scene [4]")
    ap.add_argument(
        "--fd-step", type=float, default=1e-4, help="length of the fd perturbation [1e-4]"
    )
    ap.add_argument("--out", default="/tmp/newton_diagnostics", help="run directory")
    ap.add_argument("--polish", type=int, default=0, help="exact Newton steps after the solve [0]")
    args = ap.parse_args(argv)
    if args.polish < 0 or args.polish == 1:
        ap.error(f"--polish must be 0 or at least 2 (the round-off level of u*), not {args.polish}")
    if not 1 <= args.steps <= 64 or not 1 <= args.step <= args.steps:
        ap.error(f"need 1 <= --step <= --steps <= 64, got --step {args.step} --steps {args.steps}")
    if not 0.0 < args.fd_step < 1.0:
        ap.error(f"--fd-step must lie in (0, 1), got {args.fd_step}")
    box, log, state = {}, [], {"step": 0, "solve": 0}
    iterates, polished = [], {}
    newton_cls = solver_module.NewtonSolver
    orig_j, orig_solve, orig_begin = newton_cls._J, newton_cls.solve, None

    def watched_j(self, snes, x, A, P):
        orig_j(self, snes, x, A, P)
        if state["step"] == args.step and state["solve"] == args.solve:
            iterates.append(x.copy())
            self.problem.ensure_contact_at(x)
            check(self.problem, log, args.fd_step)
            self.problem.ensure_contact_at(x)

    def counted_solve(self, *a, **k):
        state["solve"] += 1
        out = orig_solve(self, *a, **k)
        if state["step"] == args.step and state["solve"] == args.solve and args.polish > 0:
            iterates.append(self.problem.u.vector.copy())
            norms, moves, u_star = polish(self.problem, args.polish)
            errors = []
            for v in iterates:
                v.axpy(-1.0, u_star)
                errors.append(v.norm())
                v.destroy()
            polished.update(solve=out[1], plateau=norms, moves=moves, errors=errors)
            u_star.destroy()
        return out

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
        sc = demo_hertz2d.scene(
            args.refine,
            args.order,
            args.integration,
            args.steps,
            quads=not args.tri,
            recovery=args.recovery,
        )
        summary = run(
            parse_scene(sc, Path(".")), MPI.COMM_WORLD, Path(args.out), setup=setup, round_off=True
        )
    finally:
        newton_cls._J, newton_cls.solve = orig_j, orig_solve
    if polished:
        polished["round_off"] = summary["steps"][args.step - 1]["residual_round_off"]
        polished["error_level"] = s = error_level(polished["moves"])
        polished["error_order"] = cm.solve_order(polished["errors"], s)
    if MPI.COMM_WORLD.rank == 0:
        which = "main solve" if args.solve == 1 else f"solve {args.solve}"
        print(
            f"hertz2d P{args.order} {args.integration} {args.recovery}, step {args.step}, {which}:"
        )
        print("  |R|        |du|       |du|_K     fd(K du)   quad t=1/4, 1/2, 1")
        for rn, dn, e, q, dk in log:
            print(f"  {rn:.3e}  {dn:.3e}  {dk:.3e}  {e:.1e}    " + ", ".join(f"{v:.4e}" for v in q))
        steps = [x[1] for x in log]
        if len(steps) >= 3:
            c = [steps[k + 1] / steps[k] ** 2 for k in range(len(steps) - 1)]
            print("  |du_k+1|/|du_k|^2:", ", ".join(f"{v:.3g}" for v in c))
            dec = [x[4] for x in log]
            print(
                "  order of the last three |du|_K (the errors' energy norms):",
                f"{cm.observed_order(dec):.2f}",
            )
        if polished:
            print(
                "  residual norms of the solve:", ", ".join(f"{v:.3g}" for v in polished["solve"])
            )
            print(
                "  after",
                args.polish,
                "more exact steps:",
                ", ".join(f"{v:.3g}" for v in polished["plateau"]),
                f"(the step's measured round-off level f = {polished['round_off']:.3g}:"
                " ContactProblem.residual_round_off; a plateau of noise is about sqrt(2) f)",
            )
            print("  e_k = |u_k - u*|:", ", ".join(f"{v:.3g}" for v in polished["errors"]))
            q, bound = polished["error_order"]
            print(
                f"  the polished state's round-off level s = {polished['error_level']:.3g} (the "
                "median |du| of the polish steps after the first); order from the errors: "
                f"{'≥' if bound else ''}{q:.2f}"
                + (
                    " (the last error within FLOOR_FACTOR s: a bound with e_n + 2 s)"
                    if bound
                    else ""
                )
            )
    if args.polish > 0:
        return log, polished
    return log


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
