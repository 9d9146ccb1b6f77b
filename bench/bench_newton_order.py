"""The Newton order read from the residual norms, against the normal penalty.

Issue 3 asks for an observed order ≥ 1.8 in every step of the Hertz demos, read from the
residual norms (``demos/_common.step_orders``: the last three norms of each step's main
Newton solve above its round-off floor). The same Newton method reads differently with
the penalty: the residual of an error δu is K δu, and K is κ-fold stiffer in the
contact-normal displacement of active nodes (ε = κ E*/h, ε h/E* = κ) than in the bulk,
so ‖R‖/‖δu‖ moves by up to that factor as the error shifts between the contact zone and
the bulk from one iterate to the next, and the three-norm order moves with it.

For each ``--kappas`` value the demo's scene (``demos/demo_hertz2d.py``, 4 load steps,
or ``--demo hertz3d``, 2 steps) runs with ``penalty = κ E*/h_contact``, or with the
demo's own "auto" (κ = contact.AUTO_PENALTY_FACTOR = 100 with each node's facet size
h_I), and ``round_off=True``, and one line is
printed: Newton iterations and Uzawa rounds per step, the per-step orders as the demos
print them, the largest quadratic constant r_{k+1} r_0 / r_k² of each step
(``demos/_common.quadratic_constants``), the L2 pressure error (2D) or the p0 and radius
errors (3D), and the wall time. Run from the repository root (serial or under mpirun):

    /usr/bin/python3 bench/bench_newton_order.py --kappas auto 10 30 100 300
    /usr/bin/python3 bench/bench_newton_order.py --demo hertz3d --kappas auto 10 30 100 300

The same scene with other load steps, meshes and integrations (``--steps``,
``--refine``, ``--integration``: each a list, every combination runs) shows how far the
three-norm order moves when nothing but the load path's sampling or the mesh changes:

    /usr/bin/python3 bench/bench_newton_order.py --kappas auto --refine 0 1 \
        --steps 3 4 5 6 8 --integration element segment

BENCHMARKS.md §27 and §38 have the figures.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))

import _common as cm  # noqa: E402
import demo_hertz2d  # noqa: E402
import demo_hertz3d  # noqa: E402

from dolfinx_mortar.analytic import effective_modulus  # noqa: E402

#: Issue 3's threshold of the observed order (every step of the Hertz demos).
ORDER = 1.8
DEMOS = {"hertz2d": demo_hertz2d, "hertz3d": demo_hertz3d}


def _scene(
    demo: str, kappa: str, refine: int = 0, steps: int | None = None, integration: str = "element"
) -> dict:
    """The demo's scene at refinement level ``refine`` with ``steps`` load steps (None: the
    demo's own number) and ``integration``, with penalty κ E*/h_contact (E*: both bodies'
    E and ν, h_contact at that level), or its own ``"auto"`` (κ = "auto")."""
    module = DEMOS[demo]
    sc = module.scene(refine=refine, integration=integration)
    if steps is not None:
        sc["steps"]["n"] = steps
    if kappa != "auto":
        h = float(sc["mesh"]["params"]["h_contact"])
        e_star = effective_modulus(module.E, module.NU)
        for pair in sc["contact"]:
            pair["penalty"] = float(kappa) * e_star / h
    return sc


def _kappa(text: str) -> str:
    """A ``--kappas`` value: "auto" or a positive number (argparse type)."""
    if text != "auto" and not float(text) > 0.0:
        raise argparse.ArgumentTypeError(f"kappa must be 'auto' or > 0, got {text!r}")
    return text


def _level(text: str) -> int:
    """A ``--refine`` value: 0 … 3 (argparse type)."""
    if text not in ("0", "1", "2", "3"):
        raise argparse.ArgumentTypeError(f"refine must be 0, 1, 2 or 3, got {text!r}")
    return int(text)


def _count(text: str) -> int:
    """A ``--steps`` value: 1 … 64 load steps (argparse type)."""
    if not (text.isdigit() and 1 <= int(text) <= 64):
        raise argparse.ArgumentTypeError(f"steps must be 1 … 64, got {text!r}")
    return int(text)


def _errors(demo: str, summary: dict, out: Path) -> dict[str, float]:
    """The demo's relative errors against Hertz of a finished run: ``l2`` (2D), ``p0`` and
    ``radius`` (3D) (collective: rank 0 reads the CSV)."""
    m = cm.on_root(DEMOS[demo].evaluate, summary, out)
    return {"l2": m["l2"]} if demo == "hertz2d" else {"p0": m["p0_err"], "radius": m["a_err"]}


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kappas", type=_kappa, nargs="+", default=["auto", "10", "30", "100"])
    ap.add_argument("--demo", default="hertz2d", choices=sorted(DEMOS))
    ap.add_argument(
        "--refine", type=_level, nargs="+", default=[0], help="refinement levels (0-3) [0]"
    )
    ap.add_argument(
        "--steps", type=_count, nargs="+", default=[None], help="load steps [the demo's]"
    )
    ap.add_argument("--integration", nargs="+", default=["element"], choices=("element", "segment"))
    ap.add_argument("--out", default="/tmp/bench_newton_order", help="run directories")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    runs = itertools.product(args.integration, args.refine, args.steps, args.kappas)
    for integration, refine, steps, kappa in runs:
        label = f"{integration} refine={refine} steps={steps or 'demo'} kappa={kappa}"
        out = Path(args.out) / f"{args.demo}_{label.replace(' ', '_').replace('=', '')}"
        sc = _scene(args.demo, kappa, refine, steps, integration)
        summary, wall = cm.run_scene(sc, out, comm, round_off=True)
        row = {
            "integration": integration,
            "refine": refine,
            "steps": len(summary["steps"]),
            "kappa": kappa,
            "iterations": cm.newton_iterations(summary),
            "rounds": [int(st["uzawa_rounds"]) for st in summary["steps"]],
            "orders": cm.format_orders(summary),
            "order_values": cm.newton_orders(summary),
            "C": [float(f"{c:.2g}") for c in cm.quadratic_constants(summary)],
            "errors": _errors(args.demo, summary, out),
            "wall": wall,
        }
        rows.append(row)
        if comm.rank == 0:
            print(
                f"{label} iterations={row['iterations']} rounds={row['rounds']} "
                f"orders=[{row['orders']}] C={row['C']} "
                + " ".join(f"{k}={100 * v:+.3f}%" for k, v in row["errors"].items())
                + f" wall={wall:.2f}s",
                flush=True,
            )
    if comm.rank == 0 and len(rows) > 1:
        met = sum(all(q >= ORDER for q in r["order_values"]) for r in rows)
        print(f"every step's order >= {ORDER}: {met} of {len(rows)} runs", flush=True)
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
