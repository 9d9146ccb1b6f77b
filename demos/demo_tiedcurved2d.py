"""Tied curved interface: a non-flat patch test with friction, and its convergence in h.

Generator ``tiedcurved2d``: two annular sectors (θ ∈ [0, π/2]), ``inner`` r ∈ [1, 1.5]
and ``outer`` r ∈ [1.5, 2], touching along the arc r = 1.5 with non-matching meshes
(6·2^k and 9·2^k quadrilaterals along it, 3·2^k through each body at level k). Both
bodies linear elastic (E = 100, ν = 0.3, plane strain), small kinematics. Every boundary
except the interface gets the homogeneous displacement u = t H X, H = [[−e, g], [g, −e]]
(e = 0.01, g = 0.004), as a field Dirichlet condition
(:meth:`~dolfinx_mortar.problem.ContactProblem.add_dirichlet_field`). Contact: slave
``outer_surface``, master ``inner_surface``, μ = 1 (the exact state sticks:
|σ_nt|/|σ_nn| ≤ 0.19), Uzawa to 1e-9 on both multipliers. One load step from the open
state: a node that enters contact in a step carries no tangential traction in it and is
written as sliding (docs/scenes.md, "Contact CSV"), which on the coarsest levels is every
node (level 0) or some (level 1); from level 2 on every node sticks.

The exact solution is the homogeneous state: σ = λ tr(ε) I + 2μ ε, ε = sym H, uniform in
both bodies, with interface pressure p = −n·σ·n and shear n⊥·σ·n. The two faceted
interfaces leave gaps of O(h²) between them, which the contact closes: the discrete
stress departs from the uniform one in a band of width O(h) along the interface, so the
L2 stress error falls like h^1.5 (BENCHMARKS.md "tied-curved": O(h²) facet gaps).

Prints, per level: the relative L2 stress error over both bodies ‖σ_h − σ‖/‖σ‖, the
largest nodal pressure and shear errors over |σ_nn|, and the fitted rates.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_tiedcurved2d.py [--levels 4] [--refine K] [--integration segment]

``--refine K`` starts the levels at K (levels K .. K + levels − 1).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

E, NU, MU = 100.0, 0.3, 1.0
STRAIN, SHEAR = 0.01, 0.004
R1 = 1.5
SLAVE, MASTER = "outer_surface", "inner_surface"
H = np.array([[-STRAIN, SHEAR], [SHEAR, -STRAIN]])


def exact_stress() -> np.ndarray:
    """The uniform Cauchy stress (2, 2) of the imposed homogeneous strain (plane strain)."""
    lmbda, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    eps = 0.5 * (H + H.T)
    return lmbda * np.trace(eps) * np.eye(2) + 2 * mu * eps


def homogeneous(t, x):
    """u = t H X at the points x (3, n)."""
    return t * (H @ x[:2])


def scene(level: int, integration: str = "element") -> dict:
    k = 2**level
    return {
        "title": f"tied curved patch, level {level}, {integration}",
        "kinematics": "small",
        "mesh": {
            "generator": "tiedcurved2d",
            "params": {"r1": R1, "n_inner": 6 * k, "n_outer": 9 * k, "n_r": 3 * k},
        },
        "material": cm.elastic(("inner", "outer"), E, NU),
        "contact": [
            {
                "slave": SLAVE,
                "master": MASTER,
                "friction": MU,
                "integration": integration,
                "uzawa_tol": 1e-9,
                "uzawa_max": 60,
            }
        ],
        "steps": {"t_end": 1.0, "n": 1},
        "output": {"fields": ["displacement", "contact_pressure"]},
    }


class StressError:
    """Holds the problem; after the last step, the L2 stress error (collective)."""

    def __init__(self):
        self.problem = None
        self.value = None

    def setup(self, problem):
        self.problem = problem
        for name in ("inner_boundary", "outer_boundary"):
            problem.add_dirichlet_field(name, homogeneous)

    def progress(self, step, record):
        import ufl
        from dolfinx import fem

        p = self.problem
        lmbda, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
        eps = ufl.sym(ufl.grad(p.u))
        sigma = lmbda * ufl.tr(eps) * ufl.Identity(2) + 2 * mu * eps
        ex = ufl.as_matrix(exact_stress().tolist()) * float(record["t"])
        diff = sigma - ex
        dx = ufl.dx(domain=p.mesh)
        num = fem.assemble_scalar(fem.form(ufl.inner(diff, diff) * dx))
        den = fem.assemble_scalar(fem.form(ufl.inner(ex, ex) * dx))
        self.value = math.sqrt(p.comm.allreduce(num) / p.comm.allreduce(den))


def interface_errors(out_dir) -> dict:
    """Nodal interface tractions against the exact ones, over |σ_nn| max (rank 0): the
    largest and the RMS errors of p_N and |p_T| over the interior slave nodes (the two
    end nodes lie on the Dirichlet boundary of both bodies: they cannot close the facet
    gap and stay open)."""
    d = cm.final_csv(out_dir, SLAVE)
    theta = np.arctan2(d["y"], d["x"])  # reference coordinates (small strain)
    inner = (theta > theta.min() + 1e-9) & (theta < theta.max() - 1e-9)
    n = np.stack([np.cos(theta), np.sin(theta)], axis=1)  # outward from the inner body
    s = exact_stress()
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    p_ex = -np.einsum("ni,ij,nj->n", n, s, n)
    q_ex = np.einsum("ni,ij,nj->n", t, s, n)
    scale = np.abs(p_ex).max()
    ep = (d["p_N"] - p_ex)[inner] / scale
    eq = (np.abs(d["p_T0"]) - np.abs(q_ex))[inner] / scale
    return {
        "p_err": float(np.abs(ep).max()),
        "p_rms": float(np.sqrt(np.mean(ep**2))),
        "q_err": float(np.abs(eq).max()),
        "q_rms": float(np.sqrt(np.mean(eq**2))),
        "states": sorted({int(v) for v in d["state"][inner]}),
        "slave_nodes": len(theta),
    }


def main(argv=None) -> dict:
    ap = cm.parser(__doc__.splitlines()[0], "results/demo_tiedcurved2d")
    ap.add_argument(
        "--levels", type=int, default=4, help="number of mesh levels, from --refine on [4]"
    )
    args = ap.parse_args(argv)
    if args.levels < 1 or args.refine < 0:
        ap.error("--levels must be >= 1 and --refine >= 0")
    comm = MPI.COMM_WORLD
    rows = []
    for level in range(args.refine, args.refine + args.levels):
        meter = StressError()
        out = Path(args.out) / f"L{level}"
        summary, wall = cm.run_scene(
            scene(level, args.integration),
            out,
            comm,
            setup=meter.setup,
            progress=meter.progress,
        )
        meter.problem.destroy()  # setup received it: its holder frees it
        m = cm.on_root(interface_errors, out, comm=comm)
        m.update(
            level=level,
            h=R1 * (math.pi / 2) / (6 * 2**level),
            stress_err=meter.value,
            wall_time=wall,
            dofs=summary.get("dofs"),
            **cm.solver_stats(summary),
        )
        rows.append(m)
    h = [r["h"] for r in rows]
    rates = {}
    for key in ("stress_err", "p_err", "p_rms", "q_err", "q_rms"):
        e = [r[key] for r in rows]
        rates[key] = [
            math.log(e[i] / e[i + 1]) / math.log(h[i] / h[i + 1]) for i in range(len(e) - 1)
        ]
    cm.report(
        f"tied curved interface, {args.integration}, {comm.size} rank(s)",
        [
            (
                f"L{r['level']} h={r['h']:.4f} dofs={r['dofs']}",
                f"stress L2 {r['stress_err']:.3e}, p max/rms {r['p_err']:.3e}/{r['p_rms']:.3e}, "
                f"q max/rms {r['q_err']:.3e}/{r['q_rms']:.3e}, "
                f"states {r['states']}, Newton max {r['max_newton_per_solve']}, "
                f"{r['wall_time']:.1f} s",
            )
            for r in rows
        ]
        + [(f"rates {k}", ", ".join(f"{q:.2f}" for q in v)) for k, v in rates.items()],
        comm,
    )
    return {"levels": rows, "rates": rates}


if __name__ == "__main__":
    cm.script(main, "demo_tiedcurved2d")
