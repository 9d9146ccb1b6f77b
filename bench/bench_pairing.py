"""Time of the element pairing (``kernels.mortar.pair_points``) per call, in a demo's run.

Runs a demo script (``--demo``, with the arguments after ``--`` passed on) with the
kernel wrapped by a timer where the package calls it (:mod:`dolfinx_mortar.contact`:
the current pairing, at every residual evaluation; :mod:`dolfinx_mortar.tangential`:
the t_n pairings of friction, once per step with the ``nearest_first`` sweep), and
prints per kind of call their number, median and total time (the first call of each
kind left out: it may compile). The demos' own results are not changed by the timer.
Serial; for an A/B of two trees run it from one tree with ``PYTHONPATH`` set to the
other's root (the script finds the demos next to the package it imports). Run from the
repository root::

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_pairing.py --demo demo_hertz3d
    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_pairing.py --demo demo_cattaneo3d -- \\
        --quadrature-degree 12

BENCHMARKS.md §99 (session 68: the pairing without its per-call reference counts).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import tempfile
from pathlib import Path
from time import perf_counter

import numpy as np


def main(argv=None) -> dict:
    """Runs the demo; returns {"current": [s, …], "t_n": [s, …]}, the time of every call
    (the first of each kind included), and prints the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demo", default="demo_hertz3d", help="demo module [demo_hertz3d]")
    ap.add_argument("rest", nargs="*", help="the demo's arguments (after --)")
    args = ap.parse_args(argv)

    import dolfinx_mortar
    from dolfinx_mortar import contact, tangential

    demos = Path(dolfinx_mortar.__file__).resolve().parents[1] / "demos"
    sys.path.insert(0, str(demos))
    demo = importlib.import_module(args.demo)
    kernel = contact.kmortar.pair_points
    times = {"current": [], "t_n": []}

    def timed(*a):
        t = perf_counter()
        out = kernel(*a)
        times["t_n" if a[-1] else "current"].append(perf_counter() - t)
        return out

    rest = list(args.rest)
    with tempfile.TemporaryDirectory() as tmp:
        if "--out" not in rest:
            rest += ["--out", tmp]
        contact.kmortar.pair_points = timed
        try:
            demo.main(rest)
        finally:
            contact.kmortar.pair_points = kernel
    assert tangential.kmortar is contact.kmortar  # one module object: both were timed
    print(f"pair_points in {args.demo} {' '.join(args.rest)}:")
    for kind, ts in times.items():
        t = np.array(ts[1:])
        if t.size:
            print(
                f"  {kind:8s} {len(ts):5d} calls, median {1e3 * np.median(t):8.3f} ms, "
                f"total {t.sum():7.3f} s (first call left out)"
            )
    return times


if __name__ == "__main__":
    main()
