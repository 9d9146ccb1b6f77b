"""Uzawa cost against the auto-penalty factor and the acceleration of the update, on any scene.

For each penalty factor k (``penalty = "auto"`` gives ε^I = k E*/h_I) and each
acceleration of the Uzawa update (the scene key ``uzawa_acceleration``: auto, Anderson,
Irons–Tuck Aitken, none; newton on request; with friction, pairs with the lumped tangential recovery only), the scene is run once and the Newton iterations and Uzawa rounds per
step, cutbacks, wall time and the multiplier change per round of the last step (the
larger of the normal and tangential change) are printed. Run from the repository root, e.g. on the peers' problem A:

    /usr/bin/python3 bench/bench_uzawa.py ../shared/peers/scenes/hertz_A_L2.toml \\
        --factors 100 1000 10000 --acceleration anderson aitken none

(the peers' meshes are written by ``../shared/peers/export_scenes.py``; or use a scene
built on a generator, e.g. the one that ``demos/demo_hertz2d.py`` runs).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace

from mpi4py import MPI

from dolfinx_mortar import contact, uzawa
from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import load_scene


def one(scene_path: str, factor: float, acceleration: str) -> dict:
    """Run the scene with the given auto-penalty factor and acceleration (collective)."""
    factor0, contact.AUTO_PENALTY_FACTOR = contact.AUTO_PENALTY_FACTOR, factor
    scene = load_scene(scene_path)
    pairs = tuple(replace(c, uzawa_acceleration=acceleration) for c in scene.contacts)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            out = MPI.COMM_WORLD.bcast(tmp, root=0)
            s = run(replace(scene, contacts=pairs), MPI.COMM_WORLD, out_dir=out)
    finally:
        contact.AUTO_PENALTY_FACTOR = factor0
    st = s["steps"]
    changes = (
        [
            max(i["multiplier_change"], i.get("tangential_change", 0.0))
            for i in (next(iter(r.values())) for r in st[-1]["uzawa"])
        ]
        if st
        else []
    )
    return {
        "factor": factor,
        "acceleration": acceleration,
        "status": s["status"],
        "newton": [sum(x["newton_iterations"]) for x in st],
        "uzawa": [x["uzawa_rounds"] for x in st],
        "cutbacks": sum(x["cutbacks"] for x in st),
        "wall": round(sum(x["wall_time"] for x in st), 2),
        "changes": [f"{c:.1e}" for c in changes],
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--factors", type=float, nargs="+", default=[100.0])
    ap.add_argument(
        "--acceleration",
        nargs="+",
        choices=uzawa.ACCELERATIONS,
        default=[a for a in uzawa.ACCELERATIONS if a != "newton"],
        help="multiplier updates to compare [all but newton, which a frictional pair takes "
        "with the lumped tangential recovery only: auto resolves to it on lumped pairs]",
    )
    args = ap.parse_args(argv)
    rows = []
    for factor in args.factors:
        for acceleration in args.acceleration:
            row = one(args.scene, factor, acceleration)
            rows.append(row)
            if MPI.COMM_WORLD.rank == 0:
                print(row, flush=True)
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
