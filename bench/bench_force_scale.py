"""The same contact problem in other units: a Hertz demo with E and the load times a scale.

Strains and pressures / scale are the same at every scale, so a scale-free solver takes
the same Newton iterations and gives the same contact force / scale. For each ``--scales``
value the demo's scene (``demos/demo_hertz2d.py``, 4 load steps, or with ``--demo
hertz3d`` ``demos/demo_hertz3d.py``, 2 steps) runs with ``round_off=True`` and one line is
printed: status, Newton iterations and Uzawa rounds per step, the contact force's
relative error against the nominal load (``force_error``; in 3D it carries the meshed
top's area, about 1 % short of the quarter disc's) and against the first run's force
(``force_vs_first``, both / scale), and the residual's round-off level of the last step. ``--length L`` multiplies every length of the geometry and its mesh sizes by L as
well (L = 1e-3 with scale 1e9: lengths in millimetres and E = 200 GPa, both in SI units;
the contact force then scales with scale × L in 2D and scale × L² in 3D); ``--time T``
multiplies the time axis (load paths, t_end). Run from the repository root (serial or
under mpirun):

    /usr/bin/python3 bench/bench_force_scale.py --scales 1e-6 1e-3 1 1e3 1e6 1e9
    /usr/bin/python3 bench/bench_force_scale.py --scales 1e-9 1e-6 1 1e9 --atol 1e-10
    /usr/bin/python3 bench/bench_force_scale.py --demo hertz3d --scales 1 1e9 --length 1e-3
    /usr/bin/python3 bench/bench_force_scale.py --scales 1 --time 1e-6

(``--atol A``: the scene's ``[solver] atol`` is A × the scale, as a user would set it
for those units.)

BENCHMARKS.md §25 has the figures (``solver.ROUND_OFF_ATOL``, ``solver.AUTO_ATOL``,
``solver.LINE_SEARCH_ATOL``, ``generators.OCC_BOX_PAD``; docs/method-notes.md, "The
absolute tolerance and the size of the forces").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))

import demo_hertz2d  # noqa: E402
import demo_hertz3d  # noqa: E402

from dolfinx_mortar.generators import validate_params  # noqa: E402
from dolfinx_mortar.runner import run  # noqa: E402
from dolfinx_mortar.scene import parse_scene  # noqa: E402

#: per demo: its module, the load its model carries (the half or quarter of P) along
#: the axis of the contact force's normal component, that axis, and the dimension
DEMOS = {
    "hertz2d": (demo_hertz2d, demo_hertz2d.P / 2, 1, 2),
    "hertz3d": (demo_hertz3d, demo_hertz3d.P / 4, 2, 3),
}
#: the generator parameters that are lengths (the others are ratios, counts, flags)
LENGTHS = ("R", "gap0", "W", "H", "c_zone", "h_contact", "h_far")


def scaled_scene(
    scale: float,
    atol: float | None = None,
    length: float = 1.0,
    demo: str = "hertz2d",
    time: float = 1.0,
) -> dict:
    """The ``demo`` scene with E and the traction times ``scale``, every length of its
    geometry and mesh times ``length`` and its time axis (paths, t_end, output times)
    times ``time``; ``atol``: its ``[solver] atol`` (None: the scene's default)."""
    sc = DEMOS[demo][0].scene()
    if time != 1.0:
        for key in ("dirichlet", "traction"):
            for entry in sc.get(key, []):
                entry["path"] = [[row[0] * time, *row[1:]] for row in entry["path"]]
        steps = sc["steps"]
        steps["t_end"] = steps.get("t_end", 1.0) * time
        steps["output_times"] = [t * time for t in steps.get("output_times", [])]
    if atol is not None:
        sc["solver"] = {**sc.get("solver", {}), "atol": atol}
    for m in sc["material"]:
        m["E"] *= scale
    for t in sc["traction"]:
        t["path"] = [[row[0]] + [v * scale for v in row[1:]] for row in t["path"]]
    if length != 1.0:
        mesh = sc["mesh"]
        params = validate_params(mesh["generator"], mesh.get("params"))
        mesh["params"] = {k: v * length if k in LENGTHS else v for k, v in params.items()}
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
    ap.add_argument("--demo", default="hertz2d", choices=sorted(DEMOS))
    ap.add_argument(
        "--length", type=float, default=1.0, help="every length of the geometry times this"
    )
    ap.add_argument("--time", type=float, default=1.0, help="the time axis times this")
    ap.add_argument("--out", default="/tmp/bench_force_scale", help="run directories")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    module, load, axis, dim = DEMOS[args.demo]
    pair = f"{module.SLAVE}:{module.MASTER}"
    rows = []
    first = None  # the first run's contact force / (scale × length^(d−1))
    for scale in args.scales:
        out = Path(args.out) / f"{args.demo}_scale_{scale:g}_length_{args.length:g}"
        atol = None if args.atol is None else args.atol * scale
        sc = scaled_scene(scale, atol, args.length, args.demo, args.time)
        s = run(parse_scene(sc, out.parent), comm, out, round_off=True)
        row = {"scale": scale, "status": s["status"], "steps": len(s["steps"])}
        if s["steps"]:
            row["iterations"] = [int(sum(st["newton_iterations"])) for st in s["steps"]]
            row["rounds"] = [int(st["uzawa_rounds"]) for st in s["steps"]]
            row["cutbacks"] = sum(int(st["cutbacks"]) for st in s["steps"])
            f = abs(s["steps"][-1]["contact_force"][pair][axis]) / (
                scale * args.length ** (dim - 1)
            )
            first = f if first is None else first
            row["force_error"] = abs(f / load - 1.0)
            row["force_vs_first"] = abs(f / first - 1.0)
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
