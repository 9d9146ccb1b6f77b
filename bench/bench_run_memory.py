"""PETSc memory left behind by repeated runs in one process (a parameter sweep).

Runs the hertz2d demo's scene (``demos/demo_hertz2d.py``, 4 load steps, 3.3k dofs;
``--demo hertz3d`` the 3D one) ``--runs`` times through :func:`dolfinx_mortar.run` in
one process and prints, after each run, the memory PETSc has allocated and not yet
freed (``PetscMallocGetCurrentUsage``; PETSc tracks it under ``-malloc_debug``, which
this script passes to PETSc before it initializes) and the growth per run from the
second run on. A run that frees what it created leaves the figure flat. At exit PETSc
lists, under ``-malloc_debug``, every allocation still held (``[ 0] ... bytes
Function() at file:line``): where a leak comes from. Serial, from the repository
root::

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_run_memory.py --runs 5

BENCHMARKS.md §41 has the figures.
"""

from __future__ import annotations

import argparse
import ctypes
import sys
import tempfile
from pathlib import Path

import petsc4py

petsc4py.init([sys.argv[0], "-malloc_debug"])

from mpi4py import MPI  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))

import demo_hertz2d  # noqa: E402
import demo_hertz3d  # noqa: E402

from dolfinx_mortar import compat, parse_scene, run  # noqa: E402


def petsc_megabytes() -> float:
    """The memory PETSc has allocated and not freed, in MiB (local)."""
    usage = compat._petsc_c_library().PetscMallocGetCurrentUsage
    usage.argtypes = [ctypes.POINTER(ctypes.c_double)]
    usage.restype = ctypes.c_int
    value = ctypes.c_double()
    if usage(ctypes.byref(value)) != 0:
        raise RuntimeError("PetscMallocGetCurrentUsage failed")
    return value.value / 2**20


def main(argv=None) -> list[float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="runs in the process (>= 2)")
    ap.add_argument("--demo", choices=("hertz2d", "hertz3d"), default="hertz2d")
    args = ap.parse_args(argv)
    if args.runs < 2:
        ap.error("--runs must be >= 2")
    demo = demo_hertz2d if args.demo == "hertz2d" else demo_hertz3d
    usage = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.runs):
            scene = parse_scene(demo.scene(), Path(tmp))
            summary = run(scene, MPI.COMM_SELF, out_dir=Path(tmp) / "out")
            usage.append(petsc_megabytes())
            print(f"run {k + 1}: {summary['status']}, PETSc holds {usage[-1]:.3f} MiB", flush=True)
    growth = (usage[-1] - usage[0]) / (len(usage) - 1)
    print(f"growth per run after the first: {growth:.4f} MiB")
    return usage


if __name__ == "__main__":
    main()
