"""The three recoveries and the two mortar integrations on the 2D Hertz problem.

Runs the half model of ``demo_hertz2d.py`` (same mesh, loads and contact settings) for
every recovery of the nodal mixed variables (METHOD.md §3):

* ``lumped``: M → diag(A), node-local;
* ``unconstrained``: the full mortar mass matrix, p = M⁻¹F (nodal pressures may be
  negative and oscillate at the contact edge);
* ``constrained``: p = argmin_{p ≥ 0} ½ pᵀMp − pᵀF;

each with ``integration = "element"`` (slave-side quadrature, as in Temizer 2013) and
``"segment"`` (exact integration over the slave/master segments). Prints a table of: L2
relative pressure error, peak pressure error, half-width error, number of negative nodal
pressures and the most negative one, oscillation index Σ|p_{i+1} − 2 p_i + p_{i−1}|/p0 over
the active nodes, Newton iterations and wall time. Saves ``p_profiles.png`` (p/p0 against
x/a, one panel per integration, with the Hertz curve) in ``--out``.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_recoveries.py [--refine K] [--order 2] [--tri]

On the demo's quadrilaterals the lumped and constrained recoveries nearly coincide (the
structured slave mesh); on triangles (``--tri``) the constrained one is clearly better.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import demo_hertz2d as hz  # noqa: E402

RECOVERIES = ("lumped", "unconstrained", "constrained")
INTEGRATIONS = ("element", "segment")


def plot(results: dict, path: Path, integrations) -> None:
    """p/p0 against x/a per recovery, one panel per integration, with Hertz (rank 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(1, len(integrations), figsize=(6.5 * len(integrations), 4.5))
    axes = np.atleast_1d(axes)
    s = np.linspace(-1.3, 1.3, 801)
    for ax, integ in zip(axes, integrations, strict=True):
        ax.plot(s, np.sqrt(np.clip(1 - s**2, 0, None)), "k-", lw=1.2, label="Hertz")
        for rec, style in zip(RECOVERIES, ("o-", "s--", "^:"), strict=True):
            m = results[f"{rec}/{integ}"]
            x, p = (np.asarray(v) for v in m["profile"])
            ax.plot(
                x / m["a"],
                p / m["p0"],
                style,
                ms=3.5,
                lw=0.9,
                label=f"{rec}: L2 {100 * m['l2']:.2f} %, min p/p0 {m['p_min'] / m['p0']:+.3f}",
            )
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_xlim(-1.3, 1.3)
        ax.set_xlabel("x / a")
        ax.set_ylabel("p / p0")
        ax.set_title(f"hertz2d, {integ} integration")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = cm.parser(__doc__.splitlines()[0], "results/demo_recoveries", integration=False)
    ap.add_argument("--order", type=int, choices=(1, 2), default=1, help="element order [1]")
    ap.add_argument("--tri", action="store_true", help="triangles instead of quadrilaterals")
    ap.add_argument(
        "--integrations",
        default=",".join(INTEGRATIONS),
        help="comma-separated integrations to run [element,segment]",
    )
    args = ap.parse_args(argv)
    integrations = [s for s in args.integrations.split(",") if s]
    bad = [s for s in integrations if s not in INTEGRATIONS]
    if bad or not integrations:
        ap.error(
            f"--integrations: choose from {', '.join(INTEGRATIONS)} (got {args.integrations!r})"
        )
    comm = MPI.COMM_WORLD
    out = Path(args.out)
    results = {}
    for integ in integrations:
        for rec in RECOVERIES:
            sub = out / f"{rec}_{integ}"
            sc = hz.scene(args.refine, args.order, integ, quads=not args.tri, recovery=rec)
            summary, wall = cm.run_scene(sc, sub, comm)
            m = cm.on_root(hz.evaluate, summary, sub, comm=comm)
            m["wall_time"] = wall
            m["p_min"] = min(m["profile"][1])
            results[f"{rec}/{integ}"] = m
    png = out / "p_profiles.png"
    cm.on_root(plot, results, png, integrations, comm=comm)
    if comm.rank == 0:
        h = hz.H_CONTACT / 2**args.refine
        print(
            f"hertz2d half model, h_contact = {h:g}, {'P' if args.tri else 'Q'}{args.order}, "
            f"{comm.size} rank(s)"
        )
        cols = ("recovery", "integration", "L2 %", "p_max %", "a %", "neg", "min p/p0")
        cols += ("osc", "Newton", "wall s")
        print("  " + " ".join(f"{c:>13}" for c in cols))
        for key, m in results.items():
            row = (
                *key.split("/"),
                f"{100 * m['l2']:.3f}",
                f"{100 * m['p_max_err']:+.3f}",
                f"{100 * m['a_err']:+.3f}",
                str(m["negative"]),
                f"{m['p_min'] / m['p0']:+.4f}",
                f"{m['oscillation']:.4f}",
                str(sum(m["newton_iterations"])),
                f"{m['wall_time']:.2f}",
            )
            print("  " + " ".join(f"{c:>13}" for c in row))
        print(f"  profile plot: {png}")
    return {"results": results, "png": str(png)}


if __name__ == "__main__":
    cm.script(main, "demo_recoveries")
