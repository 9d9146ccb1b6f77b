"""Cost of one Newton iteration's contact work against the bulk, on hertz3d (or hertz2d).

For each mesh level the sphere is pushed into the block (a prescribed displacement,
no solve), then search + pairing (``update``) and one residual + Jacobian evaluation
(``ContactProblem.residual`` and ``jacobian``, what the Newton solver calls) are timed
``--repeat`` times; the evaluation's time is split into the contact terms' and the
bulk's as summary.json's ``timings`` split it. Medians are reported. Writes a CSV row
per level and prints a table. ``--material neo-hookean`` (finite kinematics, the bulk
assembled by FFCx at every evaluation) or ``linear-elastic`` (small kinematics, the
demos' hertz3d: the bulk is K₀ assembled once, then a product and a matrix copy per
evaluation, docs/method-notes.md "A linear bulk is evaluated, not assembled"). Run from
the repository root:

    /usr/bin/python3 bench/bench_contact_cost.py --levels 0 1 2 3 --repeat 5
    /usr/bin/python3 bench/bench_contact_cost.py --material linear-elastic --levels 0 1 2 3
    mpirun -n 2 /usr/bin/python3 bench/bench_contact_cost.py --levels 2

The claim checked (issue "Mortar normal contact", performance): contact assembly per
Newton iteration <= bulk assembly, and search time growing no faster than n log n in
the number of slave facets (the fitted exponent is printed). The row also gives the
size of the master ghost layer (``ghost_master_facets_max``: the master facets a rank
receives, on the rank that receives most) against the master facets its candidate search
takes from it (``candidate_master_facets_max``) and the master surface's size
(``master_facets``).

``--quadrature-degree N`` sets the degree of the pair's slave facet rule (element
integration: the rule on every slave facet; segment: the rule per segment), the scene's
``[[contact]] quadrature_degree``. Left out, the pair's default (element integration
without friction on P1 triangles: 12, 33 points; segment: 4, 6 points a segment
triangle; ``contact.default_quadrature_degree``)::

    /usr/bin/python3 bench/bench_contact_cost.py --material linear-elastic --h0 0.06 \
        --levels 0 --repeat 5 --quadrature-degree 6
"""

from __future__ import annotations

import argparse
import csv
import logging
import pathlib
import sys
from time import perf_counter

import numpy as np
from dolfinx import fem
from dolfinx.fem.petsc import create_vector
from mpi4py import MPI

from dolfinx_mortar.errors import SceneError
from dolfinx_mortar.runner import prepare
from dolfinx_mortar.scene import parse_scene, quadrature_degree_choice


def scene(gen: str, h: float, integration: str, material: str = "neo-hookean") -> dict:
    if gen == "hertz3d":
        bodies, slave, params = (
            ("sphere", "block"),
            "sphere_surface",
            {"h_contact": h, "h_far": 3.0, "c_zone": 1.5},
        )
    else:
        bodies, slave, params = (
            ("cylinder", "block"),
            "cylinder_surface",
            {"h_contact": h, "h_far": 2.0},
        )
    return {
        "kinematics": "finite" if material == "neo-hookean" else "small",
        "mesh": {"generator": gen, "params": params},
        "material": [{"region": b, "model": material, "E": 200.0, "nu": 0.3} for b in bodies],
        "contact": [{"slave": slave, "master": "block_top", "integration": integration}],
        "output": {"dir": "unused"},
    }, bodies[0]


def push(problem, body: str, depth: float) -> None:
    """Rigid push of the slave body by ``depth`` into the master (plus a small tilt)."""
    md, d = problem.mesh_data, problem.gdim
    cells = md.cell_tags.find(md.cell_groups[body])
    w = fem.Function(problem.V)

    def f(x):
        out = np.zeros((d, x.shape[1]))
        out[d - 1] = -depth - 0.01 * depth * x[0]
        return out

    w.interpolate(f, cells)
    problem.u.x.array[:] = w.x.array
    problem.u.x.scatter_forward()


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        MPI.COMM_WORLD.barrier()
        t0 = perf_counter()
        fn()
        MPI.COMM_WORLD.barrier()
        times.append(perf_counter() - t0)
    return float(np.median(times))


def _quadrature_degree(text: str) -> int:
    """``--quadrature-degree``: an integer from 2 to 30, checked by the rule of the scene's
    ``[[contact]] quadrature_degree`` and MortarContact's argument
    (:func:`~dolfinx_mortar.scene.quadrature_degree_choice`; 0 gave basix's one-point rule,
    silently)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"an integer from 2 to 30, got {text!r}") from None
    try:
        return quadrature_degree_choice("", value)
    except SceneError as exc:
        raise argparse.ArgumentTypeError(exc.reason) from None


def _held_by_nothing(record: logging.LogRecord) -> bool:
    """False for runner.prepare's warnings that a body (or the bodies together) is free
    in rigid motions that no [[dirichlet]] condition holds: this benchmark's scenes hold
    nothing on purpose (a prescribed push, then one residual and Jacobian, no solve), so
    those warnings say nothing here; every other record passes."""
    text = record.getMessage()
    return not (" free " in text and "no [[dirichlet]] condition holds these motions" in text)


def run_level(args, level: int, comm) -> dict:
    """Time search, contact and bulk assembly at one mesh level (collective)."""
    h = args.h0 / 2**level
    data, body = scene(args.generator, h, args.integration, args.material)
    if args.quadrature_degree is not None:
        data["contact"][0]["quadrature_degree"] = args.quadrature_degree
    runner_log = logging.getLogger("dolfinx_mortar.runner")
    runner_log.addFilter(_held_by_nothing)
    try:
        problem, _ = prepare(parse_scene(data, pathlib.Path(".")), comm)
    finally:
        runner_log.removeFilter(_held_by_nothing)
    term = problem.contacts[0]
    push(problem, body, 0.08 if args.generator == "hertz3d" else 0.05)  # Hertz approach a²/R
    x = problem.u.vector
    b = create_vector(problem.F_form)
    problem.update_contact(x)
    A = problem.create_matrix()
    split = {"contact_assembly": [], "bulk_assembly": []}

    def evaluation():
        before = dict(problem.timings)
        problem.residual(x, b)
        problem.jacobian(x, A)  # the solver's path: record, grow the pattern, insert
        for k, v in split.items():
            v.append(comm.allreduce(problem.timings[k] - before[k], op=MPI.MAX))

    evaluation()  # numba warm-up, the linear bulk's K₀
    t_search = median_time(lambda: term.update(problem.u), args.repeat)
    for v in split.values():
        v.clear()
    for _ in range(args.repeat):
        evaluation()
    t_contact = float(np.median(split["contact_assembly"]))
    t_bulk = float(np.median(split["bulk_assembly"]))
    nsf = comm.allreduce(term.slave.num_facets)
    active = comm.allreduce(int((term.p > 0).sum()))
    # the master ghost layer (search.exchange_master_facets) against the master facets
    # the candidate search takes from it, on the rank where each is largest
    ghost = comm.allreduce(term.master.num_facets, op=MPI.MAX)
    needed = comm.allreduce(int(np.unique(term.cand).size), op=MPI.MAX)
    row = {
        "generator": args.generator,
        "material": args.material,
        "integration": args.integration,
        "quadrature_points": int(term.rule[1].size),  # of the slave facet rule
        "level": level,
        "h_contact": h,
        "ranks": comm.size,
        "dofs": problem.num_dofs,
        "slave_facets": nsf,
        "slave_nodes": term.n_global_nodes,
        "master_facets": comm.allreduce(term.master_local.num_facets),
        "ghost_master_facets_max": ghost,
        "candidate_master_facets_max": needed,
        "active_nodes": active,
        "search_s": t_search,
        "contact_assembly_s": t_contact,
        "bulk_assembly_s": t_bulk,
        "contact_over_bulk": t_contact / t_bulk,
    }
    if comm.rank == 0:
        print(
            " ".join(
                f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
            ),
            flush=True,
        )
    A.destroy()
    b.destroy()
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generator", default="hertz3d", choices=["hertz3d", "hertz2d"])
    ap.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument(
        "--h0", type=float, default=0.4, help="contact-zone size at level 0 (halved per level)"
    )
    ap.add_argument("--integration", default="element", choices=["element", "segment"])
    ap.add_argument("--material", default="neo-hookean", choices=["neo-hookean", "linear-elastic"])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument(
        "--quadrature-degree",
        type=_quadrature_degree,
        default=None,
        help="degree of the slave facet rule (default: the pair's, "
        "contact.default_quadrature_degree: 12 on hertz3d's P1 triangles with element "
        "integration, 4 with segment)",
    )
    ap.add_argument("--csv", default="bench/out/contact_cost.csv")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    for level in args.levels:
        rows.append(run_level(args, level, comm))
    if comm.rank == 0:
        path = pathlib.Path(args.csv)
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        if len(rows) >= 2:
            n = np.array([r["slave_facets"] for r in rows], float)
            t = np.array([r["search_s"] for r in rows])
            slope = np.polyfit(np.log(n), np.log(t), 1)[0]
            print(f"search time ~ n^{slope:.2f} in slave facets (n log n would fit ~1.0-1.2)")
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
