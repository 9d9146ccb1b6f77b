"""The same contact problem in other units: hertz2d with E and the load times a scale.

Strains and pressures / scale are the same at every scale, so a scale-free solver takes
the same Newton iterations and gives the same contact force / scale. For each ``--scales``
value the demo's scene (``demos/demo_hertz2d.py``, 4 load steps) runs with
``round_off=True`` and one line is printed: status, Newton iterations per step, the
contact force's relative error against the applied load, and the residual's round-off
level of the last step. Run from the repository root (serial or under mpirun):

    /usr/bin/python3 bench/bench_force_scale.py --scales 1e-6 1e-3 1 1e3 1e6 1e9
    /usr/bin/python3 bench/bench_force_scale.py --scales 1e-9 1e-6 1 1e9 --atol 1e-10

(``--atol A``: the scene's ``[solver] atol`` is A × the scale, as a user would set it
for those units.)

BENCHMARKS.md §25 has the figures before and after the round-off-aware absolute tolerance
(``solver.ROUND_OFF_ATOL``; docs/method-notes.md, "The absolute tolerance and the size of
the forces").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))

import demo_hertz2d  # noqa: E402

from dolfinx_mortar.runner import run  # noqa: E402
from dolfinx_mortar.scene import parse_scene  # noqa: E402

PAIR = f"{demo_hertz2d.SLAVE}:{demo_hertz2d.MASTER}"


def scaled_scene(scale: float, atol: float | None = None) -> dict:
    """The hertz2d demo scene with E and the traction times ``scale``; ``atol``: its
    ``[solver] atol`` (None: the scene's default)."""
    sc = demo_hertz2d.scene()
    if atol is not None:
        sc["solver"] = {**sc.get("solver", {}), "atol": atol}
    for m in sc["material"]:
        m["E"] *= scale
    for t in sc["traction"]:
        t["path"] = [[row[0]] + [v * scale for v in row[1:]] for row in t["path"]]
    return sc


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scales", type=float, nargs="+", default=[1e-3, 1.0, 1e3, 1e6, 1e9])
    ap.add_argument(
        "--atol",
        type=float,
        default=None,
        help="[solver] atol of the unit scene, times each scale (default: the scene's default)",
    )
    ap.add_argument("--out", default="/tmp/bench_force_scale", help="run directories")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    for scale in args.scales:
        out = Path(args.out) / f"scale_{scale:g}"
        atol = None if args.atol is None else args.atol * scale
        s = run(parse_scene(scaled_scene(scale, atol), out.parent), comm, out, round_off=True)
        row = {"scale": scale, "status": s["status"], "steps": len(s["steps"])}
        if s["steps"]:
            row["iterations"] = [int(sum(st["newton_iterations"])) for st in s["steps"]]
            row["rounds"] = [int(st["uzawa_rounds"]) for st in s["steps"]]
            row["cutbacks"] = sum(int(st["cutbacks"]) for st in s["steps"])
            fy = s["steps"][-1]["contact_force"][PAIR][1]
            row["force_error"] = abs(2.0 * fy / (demo_hertz2d.P * scale) - 1.0)
            row["round_off"] = s["steps"][-1].get("residual_round_off")
        rows.append(row)
        if comm.rank == 0:
            print(
                " ".join(
                    f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
                ),
                flush=True,
            )
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
