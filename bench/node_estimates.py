"""estimate_nodes against gmsh's count on the unstructured generators (session 54).

For each generator named (default: all seven whose bodies gmsh meshes by a size field),
its defaults and variants (h_contact × 2, / 2, and / 4 in 2D; quads; grading 0.1, 0.05
and 1.0; c_zone × 2; h_far / 2; order 2; a variant the generator refuses is reported
and skipped): ``generators.build`` in a fresh gmsh model, its ``num_nodes`` and
``estimate_nodes`` of the same parameters, one JSON line each. Serial, gmsh only (no
dolfinx, no MPI); about a minute in all on one core.

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/node_estimates.py [hertz2d,twist3d,...]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gmsh  # noqa: E402

import dolfinx_mortar.generators as G  # noqa: E402
from dolfinx_mortar.errors import SceneError  # noqa: E402

UNSTRUCTURED = ("hertz2d", "cattaneo2d", "wedge2d", "ironing2d", "hertz3d", "ironing3d", "twist3d")
#: parameter -> a number, or a factor on the default ("x2", "/2", "/4")
VARIANTS = (
    {},
    {"h_contact": "x2"},
    {"h_contact": "/2"},
    {"h_contact": "/4"},  # 2D only
    {"quads": True},
    {"grading": 0.1},
    {"grading": 0.05},
    {"c_zone": "x2"},
    {"h_far": "/2"},
    {"order": 2},
    {"grading": 1.0},
)


def _params(name: str, variant: dict) -> dict:
    default = {k: v[1] for k, v in G.GENERATORS[name].params.items()}
    scale = {"x2": 2.0, "/2": 0.5, "/4": 0.25}
    return {k: default[k] * scale[v] if v in scale else v for k, v in variant.items()}


def main(names) -> None:
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        for name in names:
            for variant in VARIANTS:
                if G.GENERATORS[name].gdim == 3 and variant.get("h_contact") == "/4":
                    continue
                params = _params(name, variant)
                try:
                    estimate = G.estimate_nodes(name, G.validate_params(name, params))
                except SceneError as exc:
                    print(json.dumps({"name": name, "params": params, "refused": str(exc)}))
                    continue
                t0 = time.perf_counter()
                gmsh.model.add(name)
                meta = G.build(name, params)
                gmsh.model.remove()
                row = {
                    "name": name,
                    "params": params,
                    "num_nodes": meta["num_nodes"],
                    "estimate": round(estimate),
                    "estimate/num_nodes": round(estimate / meta["num_nodes"], 3),
                    "seconds": round(time.perf_counter() - t0, 2),
                }
                print(json.dumps(row), flush=True)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main(sys.argv[1].split(",") if len(sys.argv) > 1 else UNSTRUCTURED)
