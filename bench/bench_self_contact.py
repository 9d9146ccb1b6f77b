"""Self-contact against its two-body split under mesh refinement (README's self-contact
row; BENCHMARKS.md §74).

The C of ``tests/test_contact_topology.py`` (its mesh and scene helpers): one body whose
arms are pressed together (slave and master groups on the same body), and the same mesh
cut along its mirror line into two bodies held at u_y = 0 on the cut. The two contact
forces differ by a discretization error that vanishes with h; this prints, for h =
0.125, 0.125/2, 0.125/4, the split's normal force F_y and the relative differences of
the y and x components (each divided by |F_y|).

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_self_contact.py --out DIR
    mpirun -n 2 $PY bench/bench_self_contact.py --out DIR

Collective; prints on rank 0.
"""

import argparse
import pathlib
import sys

from mpi4py import MPI

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
import test_contact_topology as topo  # noqa: E402


def main(argv=None) -> list:
    """Run the three refinements; returns [(h, F_y, rel_y, rel_x)] (every rank)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, type=pathlib.Path, help="scratch directory")
    ap.add_argument("--levels", type=int, default=3, help="refinements (h halved each)")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    rows = []
    for level in range(args.levels):
        h = 0.125 / 2**level
        force = {}
        for split in (False, True):
            mesh = args.out / f"c{level}_{'split' if split else 'one'}.msh"
            topo._c_mesh(mesh, split, h)
            out = args.out / f"run{level}_{'split' if split else 'one'}"
            force[split] = topo._force(topo._c_scene(mesh, split), out, comm)
        one, two = force[False], force[True]
        rel_y = abs(one[1] - two[1]) / abs(two[1])
        rel_x = abs(one[0] - two[0]) / abs(two[1])
        rows.append((h, float(two[1]), float(rel_y), float(rel_x)))
        if comm.rank == 0:
            print(f"h = {h:.5f}: F_y = {two[1]:.6f}, rel. diff y {rel_y:.2e}, x {rel_x:.2e}")
    return rows


if __name__ == "__main__":
    main()
