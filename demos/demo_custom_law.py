"""A bulk law of your own, written in UFL: 2D Hertz with a compressible Mooney–Rivlin solid.

The law is a stored-energy density ψ(F) registered under a name with
``dolfinx_mortar.register_law`` and then named as ``model`` in the scene's
``[[material]]``; the bulk differentiates it with UFL (P = ∂ψ/∂F, the Jacobian its exact
Hessian), as for the built-in laws. Here, in plane strain (F₃₃ = 1),

    ψ = c₁ (Ī₁ − 3) + c₂ (Ī₂ − 3) + K/2 (J − 1)²,
    Ī₁ = J^(−2/3) I₁,  Ī₂ = J^(−4/3) I₂,  I₁ = tr C + 1,  I₂ = (I₁² − tr C² − 1)/2,

with c₁ = (1 − β) μ/2, c₂ = β μ/2 (``--beta``, default 0.3), so that its small-strain
shear modulus is μ = E/(2(1 + ν)) and its bulk modulus K = E/(3(1 − 2ν)): the material's
E and ν, which the contact pair also reads for its E* (``penalty = "auto"``).

The scene is ``demo_hertz2d.py``'s half model (R = 8, P = 10, E = 200, ν = 0.3,
quadrilaterals, lumped recovery, element integration, 4 load steps) in finite
kinematics. The strains stay small (p0/E ≈ 3 %), so Hertz's solution is the reference
for any law with these small-strain moduli; the demo runs the built-in neo-Hookean law on
the same scene first, then the registered law. Both print their errors against Hertz (the
measured load) and their wall time (the first run's includes loading the compiled contact
kernels, about 0.5 s; the Mooney–Rivlin bulk costs about 3× the neo-Hookean one to
assemble, its integrand being longer).

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_custom_law.py [--refine K] [--beta 0.3]
"""

from __future__ import annotations

import sys
from pathlib import Path

import ufl
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import demo_hertz2d as hz  # noqa: E402

from dolfinx_mortar import register_law  # noqa: E402
from dolfinx_mortar.bulk import lame  # noqa: E402

LAW = "mooney-rivlin"


def mooney_rivlin(beta: float):
    """ψ(F, E, ν) of the compressible Mooney–Rivlin law above (plane strain in 2D)."""

    def psi(F, E, nu):
        _, mu = lame(E, nu)
        K = E / (3.0 * (1.0 - 2.0 * nu))
        c1, c2 = (1.0 - beta) * mu / 2.0, beta * mu / 2.0
        d = F.ufl_shape[0]
        C = F.T * F
        J = ufl.det(F)
        extra = 1.0 if d == 2 else 0.0  # C₃₃ = 1 in plane strain
        I1 = ufl.tr(C) + extra
        I2 = 0.5 * (I1**2 - ufl.tr(C * C) - extra)
        I1b, I2b = J ** (-2.0 / 3.0) * I1, J ** (-4.0 / 3.0) * I2
        return c1 * (I1b - 3.0) + c2 * (I2b - 3.0) + K / 2.0 * (J - 1.0) ** 2

    return psi


def scene(refine: int, model: str) -> dict:
    """demo_hertz2d's scene at level ``refine``, finite kinematics, both bodies ``model``."""
    sc = hz.scene(refine)
    sc["title"] = f"hertz2d half model, refine {refine}, {model}"
    sc["kinematics"] = "finite"
    for mat in sc["material"]:
        mat["model"] = model
    return sc


def main(argv=None) -> dict:
    ap = cm.parser(__doc__.splitlines()[0], "results/demo_custom_law", integration=False)
    ap.add_argument(
        "--beta", type=float, default=0.3, help="share c₂/(c₁ + c₂) of the second invariant [0.3]"
    )
    args = ap.parse_args(argv)
    if not 0.0 <= args.beta <= 1.0:
        ap.error(f"--beta must lie in [0, 1], got {args.beta:g}")
    comm = MPI.COMM_WORLD
    register_law(LAW, mooney_rivlin(args.beta), replace=True)
    out = Path(args.out)
    results = {}
    for model in ("neo-hookean", LAW):
        summary, wall = cm.run_scene(scene(args.refine, model), out / model, comm)
        m = cm.on_root(hz.evaluate, summary, out / model, comm=comm)
        m["wall_time"] = wall
        results[model] = m
    rows = []
    for model, m in results.items():
        rows += [
            (f"{model}: L2 pressure error", f"{100 * m['l2']:.3f} %"),
            (f"{model}: p_max error", f"{100 * m['p_max_err']:+.3f} %"),
            (f"{model}: half-width error", f"{100 * m['a_err']:+.3f} %"),
            (f"{model}: force balance", f"{m['force_balance']:.3e}"),
            (f"{model}: Newton iterations", str(m["newton_iterations"])),
            (f"{model}: wall time", f"{m['wall_time']:.2f} s"),
        ]
    first = results[LAW]
    cm.report(
        f"hertz2d (half model), finite kinematics, h_contact = {hz.H_CONTACT / 2**args.refine:g}, "
        f"Mooney–Rivlin β = {args.beta:g} against neo-Hookean, {first['ranks']} rank(s), "
        f"{first['dofs']} dofs",
        rows,
        comm,
    )
    return results


if __name__ == "__main__":
    cm.script(main, "demo_custom_law")
