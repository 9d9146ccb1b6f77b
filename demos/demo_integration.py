"""Mortar integration on the 2D Hertz problem: "element" against "segment".

Runs the half model of ``demo_hertz2d.py`` (same mesh, loads and contact settings,
lumped recovery) once with ``integration = "element"`` (slave-side quadrature, as in
Temizer 2013) and once with ``integration = "segment"`` (exact integration over the
slave/master segments), and prints a table of: L2 relative pressure error, peak
pressure error, negative nodal pressures, oscillation index
Σ|p_{i+1} - 2 p_i + p_{i-1}|/p0 over the active nodes, Newton iterations and wall time.
Saves ``p_profiles.png`` (p/p0 against x/a for both, with the Hertz curve) in ``--out``.

The other two recoveries of the mixed variables, "unconstrained" and "constrained"
(METHOD.md section 3), are not implemented in the library yet: only "lumped" is
compared here.

Run::

    mpirun -n 2 python3 demos/demo_integration.py [--refine K] [--order 2]
"""

from __future__ import annotations

import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import demo_hertz2d as hz  # noqa: E402

INTEGRATIONS = ("element", "segment")
NOT_IMPLEMENTED = ("unconstrained", "constrained")


def plot(results: dict, path: Path) -> None:
    """p/p0 against x/a for each integration, with the Hertz profile (rank 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(7, 4.5))
    any_m = next(iter(results.values()))
    s = np.linspace(-1.3, 1.3, 801)
    ax.plot(s, np.sqrt(np.clip(1 - s**2, 0, None)), "k-", lw=1.2, label="Hertz")
    for (name, m), style in zip(results.items(), ("o-", "s--"), strict=False):
        x, p = (np.asarray(v) for v in m["profile"])
        ax.plot(
            x / m["a"],
            p / m["p0"],
            style,
            ms=3.5,
            lw=0.9,
            label=f"{name}: L2 {100 * m['l2']:.2f} %, p_max {100 * m['p_max_err']:+.2f} %",
        )
    ax.set_xlim(-1.3, 1.3)
    ax.set_xlabel("x / a")
    ax.set_ylabel("p / p0")
    ax.set_title(f"hertz2d, lumped recovery, a = {any_m['a']:.4f}, p0 = {any_m['p0']:.4f}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = cm.parser(__doc__.splitlines()[0], "results/demo_integration", integration=False)
    ap.add_argument("--order", type=int, choices=(1, 2), default=1, help="element order [1]")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    out = Path(args.out)
    results = {}
    for name in INTEGRATIONS:
        sub = out / name
        summary, wall = cm.run_scene(hz.scene(args.refine, args.order, name), sub, comm)
        m = cm.on_root(hz.evaluate, summary, sub, comm=comm)
        m["wall_time"] = wall
        results[name] = m
    png = out / "p_profiles.png"
    cm.on_root(plot, results, png, comm=comm)
    if comm.rank == 0:
        h = hz.H_CONTACT / 2**args.refine
        print(
            f"hertz2d half model, h_contact = {h:g}, P{args.order}, lumped recovery, "
            f"{comm.size} rank(s)"
        )
        print(f"  recoveries {', '.join(NOT_IMPLEMENTED)}: not implemented yet (lumped only)")
        cols = ("integration", "L2 %", "p_max %", "a %", "neg", "osc", "Newton", "wall s")
        print("  " + " ".join(f"{c:>12}" for c in cols))
        for name, m in results.items():
            row = (
                name,
                f"{100 * m['l2']:.3f}",
                f"{100 * m['p_max_err']:+.3f}",
                f"{100 * m['a_err']:+.3f}",
                str(m["negative"]),
                f"{m['oscillation']:.4f}",
                str(sum(m["newton_iterations"])),
                f"{m['wall_time']:.2f}",
            )
            print("  " + " ".join(f"{c:>12}" for c in row))
        print(
            "  Newton iterations per step: "
            + "; ".join(f"{n} {m['newton_iterations']}" for n, m in results.items())
        )
        print(f"  profile plot: {png}")
    return {"results": results, "png": str(png), "not_implemented": list(NOT_IMPLEMENTED)}


if __name__ == "__main__":
    cm.script(main, "demo_integration")
