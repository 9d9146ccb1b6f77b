"""Frictional contact patch test: uniform pressure and shear, in stick or in uniform sliding.

Two stacked blocks (generators ``patch2d`` / ``patch3d``, non-matching interface
meshes), linear elastic with E = 100 and ν = 0 (so a uniform stress state needs
no lateral constraint), small kinematics, Coulomb friction μ = 0.5 on the
interface (slave ``upper_bottom``, master ``lower_top``). ``lower_bottom`` is
clamped. The exact solution is the uniform stress σ_yy = −p0, σ_xy = q (z for
y in 3D) in both blocks, loaded by the tractions of that stress on every other
boundary face: (q, −p0) on ``upper_top`` and the vertical shear (0, ∓q) on the
sides x = 0 and x = L.

- ``--mode stick`` (default): q = 0.4 p0 < μ p0. Every slave node must stick with
  p_N = p0 and the tangential traction of the master on the slave p_T0 = −q.
- ``--mode slide``: the lower block is longer (it overhangs the upper one by 0.2,
  so the slave never leaves it) and rigid (every boundary of it clamped, the
  master surface included); ``upper_top`` is driven sideways by 0.05 (u_x
  prescribed) under the pressure p0, with the side shear q = μ p0 of the
  sliding state. Every node must slip with p_N = p0 and p_T0 = −μ p0.

- ``--mode deformable`` (``--slide-steps N`` [4]): both blocks deformable (ν = 0.3, so
  that they stretch along the interface), the roles swapped: the lower block (1.4 long,
  margin 0.2, the COARSER side: 5 elements in 2D, 7 × 7 in 3D) is the slave, held on
  ``lower_top`` and ``lower_bottom`` at the exact (deforming) displacement; the upper
  block (the master, 7 resp. 6 × 6 elements) is free at the interface and slides over
  it, u_x (and u_y in 3D) of ``upper_top`` prescribed. The master surface is always
  covered, so its equilibrium sees the whole traction and decides where the tangential
  traction acts on it. Step 1 (t in [0, 1]) presses: p(t) = p0 t, τ = 0, no slip; the N
  sliding steps (step k in [k, k + 1]) add the slide s(t) = SLIDE (t − 1)/N while the
  shear τ = σ_xz rises to μ p0 over the first of them. Exact solution (z the normal
  coordinate, y in 2D; the interface z = 0; G = E/(2(1 + ν))), for both blocks:

      σ_zz = −p, σ_xz = τ, every other σ_ij = 0,
      u_x = ε_t x + (τ/G) z + s(t) [upper only],  u_y = ε_t y [3D],  u_z = ε_n z,
      2D (plane strain): ε_t = ν(1 + ν) p/E, ε_n = −(1 − ν²) p/E;  3D: ε_t = ν p/E, ε_n = −p/E,

  loaded by (0, −p) on ``upper_top`` and the shear (0, ∓τ) on the sides x = 0, L (and
  −0.2, 1.2); the faces y = 0, L of 3D are free. The interface slips by s(t) at every
  point (uniformly: both blocks stretch alike). A slave node holds p_N = p0 and
  |p_T| = μ p0. A held slave surface needs the coarser mesh (its multipliers are fixed by
  the master's equilibrium alone: with the slave finer the press step oscillates ±20 %).
  Measured, 2D, ``--integration segment`` (1 and 2 ranks alike): the press step to 1e-9
  (|p_N/p0 − 1| 9e-11, |p_T|/p0 1e-9), the normal force to 1e-11 in every step; the
  slave nodes that the master's ends cover in part miss by a FIRST-ORDER term in the
  step: max |p_N/p0 − 1| 3.55, 1.79, 0.89, 0.44 with N = 2, 4, 8, 16 (0.47 %, 0.44 %,
  0.39 %, 0.20 % at the two wholly covered nodes).
  The tangential traction acts on the master at the t_n projection ζ_n, one step's slide
  from the current one (docs/method-notes.md, "Friction"): with the study54-S prototype
  of the traction at the current projection (element integration only) the errors no
  longer depend on N (element: 0.353 → 0.432 from N = 4 to 8 now, 0.506 and 0.506 with
  the prototype; element integration's quadrature of the partly covered end facets
  dominates there: 2.9 in the press step already). 3D (segment, 2 / 4 / 8 sliding steps):
  the press step to 1.1e-10, Uzawa rounds at most 4 per step, no cutback, the wholly
  covered nodes 0.73 %, 0.35 %, 0.16 %, the partly covered ones 0.21 and 0.15 with 4 and 8
  steps (with 2, 1.0: a sliver node, pure penalty, at p_N = 6e-4). The master's edges
  y = 0, L lie on slave node rows: the nodes beyond them are sliver nodes
  (``uzawa.SEGMENT_SLIVER_FRACTION``; before session 55 they stalled every sliding step).

Both to round-off with ``--integration segment``, to the quadrature error of the
element rule with ``element``: ≤ 2 % on quadrilaterals, triangles and hexahedra, 6.9 %
(p_N) and 3.3 % (p_T) in 3D stick with ``--tri`` (tetrahedra; BENCHMARKS.md §4). The
slide mode's master is rigid: round-off there with either.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_friction_patch.py [--dim 3] [--mode slide] [--integration segment]
        [--uzawa-acceleration newton] [--mode deformable --slide-steps 8]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

E, NU, MU = 100.0, 0.0, 0.5
P0, L, H = 2.0, 1.0, 0.5
Q_STICK = 0.4 * P0
SLIDE = 0.05


def scene(dim: int, mode: str, integration: str, refine: int = 0, quads: bool = True) -> dict:
    """Scene dict of the frictional patch test (see the module docstring)."""
    counts = (5, 7) if dim == 2 else (4, 5)
    q = Q_STICK if mode == "stick" else MU * P0
    z = dim - 1  # the normal direction
    zero = [0.0] * dim

    def vec(normal, shear):
        v = [0.0] * dim
        v[z], v[0] = normal, shear
        return v

    side = []
    for body in ("lower", "upper") if mode == "stick" else ("upper",):
        side += [
            {"boundary": f"{body}_left", "path": [[0.0, *zero], [1.0, *vec(-q, 0.0)]]},
            {"boundary": f"{body}_right", "path": [[0.0, *zero], [1.0, *vec(q, 0.0)]]},
        ]
    dirichlet = [
        {
            "boundary": "lower_bottom",
            "components": list(range(dim)),
            "path": [[0, *zero], [1, *zero]],
        }
    ]
    if mode == "stick":
        top = [{"boundary": "upper_top", "path": [[0.0, *zero], [1.0, *vec(-P0, q)]]}]
    else:
        top = [{"boundary": "upper_top", "path": [[0.0, *zero], [1.0, *vec(-P0, 0.0)]]}]
        dirichlet.append(
            {"boundary": "upper_top", "components": [0], "path": [[0.0, 0.0], [1.0, SLIDE]]}
        )
        rigid = ["lower_top", "lower_left", "lower_right"]
        if dim == 3:
            rigid += ["lower_front", "lower_back"]
        for b in rigid:
            dirichlet.append(
                {"boundary": b, "components": list(range(dim)), "path": [[0, *zero], [1, *zero]]}
            )
    sc = _patch_scene(
        f"friction patch {dim}D {mode}, {integration}, refine {refine}",
        dim,
        counts,
        refine,
        0.0 if mode == "stick" else 0.2,
        quads,
        NU,
        ("upper_bottom", "lower_top"),
        integration,
    )
    sc.update({"dirichlet": dirichlet, "traction": top + side, "steps": {"t_end": 1.0, "n": 2}})
    return sc


def _patch_scene(
    title: str,
    dim: int,
    counts: tuple,
    refine: int,
    margin: float,
    quads: bool,
    nu: float,
    pair: tuple,
    integration: str,
) -> dict:
    """The part of a patch scene dict that every mode shares: the patch mesh (``counts``:
    elements along x of the lower and upper blocks, times 2**refine), both blocks elastic
    (E, ``nu``), one frictional pair (``pair``: slave, master) with the auto penalty and
    tight Uzawa rounds, and the contact fields in the output."""
    k = 2**refine
    return {
        "title": title,
        "kinematics": "small",
        "mesh": {
            "generator": f"patch{dim}d",
            "params": {
                "L": L,
                "H": H,
                "n_lower": counts[0] * k,
                "n_upper": counts[1] * k,
                "n_y": 3 * k,
                "margin": margin,
                "quads": quads,
            },
        },
        "material": cm.elastic(("lower", "upper"), E, nu),
        "contact": [
            {
                "slave": pair[0],
                "master": pair[1],
                "friction": MU,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": 1e-9,
                "uzawa_max": 40,
            }
        ],
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def evaluate(summary: dict, out_dir, dim: int, mode: str) -> dict:
    """Metrics of a finished run (rank 0: reads the final CSV)."""
    d = cm.final_csv(out_dir, "upper_bottom")
    q = Q_STICK if mode == "stick" else MU * P0
    want_state = 1 if mode == "stick" else 2
    pt = d["p_T0"]
    F = cm.contact_force(summary, "upper_bottom:lower_top")
    area = L ** (dim - 1)
    return {
        "p_err": float(np.max(np.abs(d["p_N"] / P0 - 1.0))),
        "q_err": float(np.max(np.abs(-pt / q - 1.0))),
        "q_cross": float(np.max(np.abs(d["p_T1"]))) / q if dim == 3 else 0.0,
        "wrong_state": int(np.sum(d["state"] != want_state)),
        "slave_nodes": len(pt),
        "force_normal_err": abs(F[dim - 1] / (P0 * area) - 1.0),
        "force_tangential_err": abs(-F[0] / (q * area) - 1.0),
        **cm.solver_stats(summary),
        "modelled": summary["modelled"]["contact_pairs"]["upper_bottom:lower_top"],
    }


# ---------------------------------------------------------------- mode "deformable"
#: the deformable-master sliding test: ν > 0, so that the blocks stretch along the
#: interface (ε_xx ≠ 0) and the master's interface points move apart as they are loaded
NU_DEF = 0.3
MARGIN_DEF = 0.2
#: elements along x (and y) of the lower (slave, 1.4 long) and upper (master, 1.0) blocks
DEF_COUNTS = {2: (5, 7), 3: (7, 6)}


def exact_state(dim: int, t: float, n_slide: int) -> dict:
    """The exact state of mode "deformable" at time t (one unit of time per step: the
    press in [0, 1], sliding step k in [k, k + 1]): pressure p, interface shear τ, slide
    s(t) (SLIDE over the n_slide steps), the strains ε_t along x (and y) and ε_n through
    the thickness, and the engineering shear γ = τ/G (E = 100, ν = NU_DEF; the paths are
    piecewise linear in t, as the tractions')."""
    p = P0 * min(max(t, 0.0), 1.0)
    tau = MU * P0 * min(max(t - 1.0, 0.0), 1.0)
    s = SLIDE * max(0.0, t - 1.0) / n_slide
    if dim == 2:  # plane strain (ε_zz = 0), σ_xx = 0
        eps_t = NU_DEF * (1 + NU_DEF) * p / E
        eps_n = -(1 - NU_DEF**2) * p / E
    else:  # σ_xx = σ_yy = 0
        eps_t = NU_DEF * p / E
        eps_n = -p / E
    gamma = 2 * (1 + NU_DEF) * tau / E
    return {"p": p, "tau": tau, "s": s, "eps_t": eps_t, "eps_n": eps_n, "gamma": gamma}


def exact_displacement(dim: int, t: float, x: np.ndarray, body: str, n_slide: int) -> np.ndarray:
    """u (dim, npts) of mode "deformable" at the reference points x (3, npts), time t:

        u_x = ε_t x + γ z + s(t) [upper only],  u_y = ε_t y (3D),  u_z = ε_n z

    (z: the normal coordinate, y in 2D; the interface at z = 0)."""
    e = exact_state(dim, t, n_slide)
    z = x[dim - 1]
    u = np.zeros((dim, x.shape[1]))
    u[0] = e["eps_t"] * x[0] + e["gamma"] * z + (e["s"] if body == "upper" else 0.0)
    if dim == 3:
        u[1] = e["eps_t"] * x[1]
    u[dim - 1] = e["eps_n"] * z
    return u


def deformable_scene(
    dim: int, integration: str, n_slide: int = 4, refine: int = 0, quads: bool = True
) -> dict:
    """Scene dict of mode "deformable" (the module docstring); its Dirichlet fields are
    :func:`deformable_setup`'s."""
    z = dim - 1
    zero = [0.0] * dim

    def vec(comp, value):
        v = [0.0] * dim
        v[comp] = value
        return v

    q = MU * P0
    traction = [{"boundary": "upper_top", "path": [[0.0, *zero], [1.0, *vec(z, -P0)]]}]
    for body in ("lower", "upper"):
        for side, sign in (("left", -1.0), ("right", 1.0)):
            traction.append(
                {
                    "boundary": f"{body}_{side}",
                    "path": [[0.0, *zero], [1.0, *zero], [2.0, *vec(z, sign * q)]],
                }
            )
    sc = _patch_scene(
        f"friction patch {dim}D deformable, {integration}, {n_slide} sliding steps",
        dim,
        DEF_COUNTS[dim],
        refine,
        MARGIN_DEF,
        quads,
        NU_DEF,
        ("lower_top", "upper_bottom"),
        integration,
    )
    sc.update({"traction": traction, "steps": {"t_end": 1.0 + n_slide, "n": 1 + n_slide}})
    return sc


def deformable_setup(dim: int, n_slide: int):
    """The ``setup(problem)`` hook of mode "deformable": the exact displacement held on
    ``lower_bottom`` and ``lower_top`` (every component), and u_x (and u_y in 3D) on
    ``upper_top``."""

    def field(body):
        return lambda t, x: exact_displacement(dim, t, x, body, n_slide)

    def setup(problem):
        problem.add_dirichlet_field("lower_bottom", field("lower"))
        problem.add_dirichlet_field("lower_top", field("lower"))
        problem.add_dirichlet_field("upper_top", field("upper"), components=list(range(dim - 1)))

    return setup


def evaluate_deformable(summary: dict, out_dir, dim: int, n_slide: int, refine: int = 0) -> dict:
    """Metrics of a finished mode-"deformable" run (rank 0: reads the final CSV): the
    errors of p_N and |p_T| at the slave nodes in contact (state != 0) against p0 and
    μ p0, the same over the nodes whose facets the master covers wholly, and the contact
    force against the exact one on the master's footprint."""
    d = cm.final_csv(out_dir, "lower_top")
    e = exact_state(dim, 1.0 + n_slide, n_slide)
    q = MU * P0
    on = d["state"] != 0
    h = (L + 2 * MARGIN_DEF) / DEF_COUNTS[dim][0] / 2**refine  # the slave facet size
    xs = d["x"] * (1 + e["eps_t"])  # current positions of the slave nodes
    lo, hi = e["s"], L * (1 + e["eps_t"]) + e["s"]  # the master's footprint along x
    inner = on & (xs - h >= lo) & (xs + h <= hi)
    if dim == 3:
        ys = d["y"] * (1 + e["eps_t"])
        inner &= (ys - h >= 0.0) & (ys + h <= L * (1 + e["eps_t"]))
    pt = d["p_T0"]
    d1 = cm.step_csv(out_dir, "lower_top", 1)  # the press step: exact to round-off
    on1 = d1["state"] != 0
    press_q = np.abs(d1["p_T0"][on1])
    if dim == 3:
        press_q = np.hypot(press_q, d1["p_T1"][on1])
    F = cm.contact_force(summary, "lower_top:upper_bottom")
    area = L ** (dim - 1)  # small kinematics: the contact integrals over the reference facets
    return {
        "press_p_err": float(np.max(np.abs(d1["p_N"][on1] / P0 - 1.0))),
        "press_q": float(press_q.max()) / P0,
        "press_nodes_on": int(on1.sum()),
        "p_err": float(np.max(np.abs(d["p_N"][on] / P0 - 1.0))),
        "q_err": float(np.max(np.abs(np.abs(pt[on]) / q - 1.0))),
        "p_err_inner": float(np.max(np.abs(d["p_N"][inner] / P0 - 1.0), initial=0.0)),
        "q_err_inner": float(np.max(np.abs(np.abs(pt[inner]) / q - 1.0), initial=0.0)),
        "q_sign": sorted({int(v) for v in np.sign(pt[on])}),
        "q_cross": float(np.max(np.abs(d["p_T1"][on]))) / q if dim == 3 else 0.0,
        "states": sorted({int(v) for v in d["state"][on]}),
        "slave_nodes_on": int(on.sum()),
        "slave_nodes_inner": int(inner.sum()),
        "force": F.tolist(),
        "force_normal_err": abs(abs(F[dim - 1]) / (P0 * area) - 1.0),
        "force_tangential_err": abs(abs(F[0]) / (q * area) - 1.0),
        **cm.solver_stats(summary),
        "modelled": summary["modelled"]["contact_pairs"]["lower_top:upper_bottom"],
    }


def main(argv=None) -> dict:
    ap = cm.parser(
        "Frictional contact patch test",
        "results/demo_friction_patch",
        frame=True,
        acceleration=True,
        quadrature=True,
    )
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2, help="dimension [2]")
    ap.add_argument(
        "--mode", choices=("stick", "slide", "deformable"), default="stick", help="[stick]"
    )
    ap.add_argument("--tri", action="store_true", help="triangles/tetrahedra")
    ap.add_argument(
        "--slide-steps", type=int, default=4, help="sliding steps of mode deformable [4]"
    )
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.mode == "deformable":
        return _main_deformable(args, comm)
    sc = scene(args.dim, args.mode, args.integration, args.refine, quads=not args.tri)
    cm.set_acceleration(cm.set_frame(sc, args.frame), args.uzawa_acceleration)
    cm.set_quadrature(sc, args.quadrature_degree)
    summary, wall = cm.run_scene(sc, args.out, comm)
    m = cm.on_root(evaluate, summary, args.out, args.dim, args.mode, comm=comm)
    m["wall_time"] = wall
    cm.report(
        f"friction patch {args.dim}D, {args.mode}, {args.integration}: "
        f"{m['slave_nodes']} slave nodes, {comm.size} rank(s)",
        [
            ("max |p_N/p0 - 1|", f"{m['p_err']:.3e}"),
            ("max |p_T/q - 1|", f"{m['q_err']:.3e}"),
            ("nodes in the wrong state", str(m["wrong_state"])),
            (
                "contact force errors (n, t)",
                f"{m['force_normal_err']:.2e}, {m['force_tangential_err']:.2e}",
            ),
            ("dissipation per step", str(m["dissipation"])),
            ("Newton iterations", str(m["newton_iterations"])),
            ("Uzawa rounds", str(m["uzawa_rounds"])),
            ("wall time", f"{wall:.2f} s"),
        ],
        comm,
    )
    return m


def _main_deformable(args, comm) -> dict:
    """main() of mode "deformable"."""
    n = args.slide_steps
    sc = deformable_scene(args.dim, args.integration, n, args.refine, quads=not args.tri)
    cm.set_acceleration(cm.set_frame(sc, args.frame), args.uzawa_acceleration)
    cm.set_quadrature(sc, args.quadrature_degree)
    setup = deformable_setup(args.dim, n)
    summary, wall = cm.run_scene(sc, args.out, comm, setup=setup)
    m = cm.on_root(evaluate_deformable, summary, args.out, args.dim, n, args.refine, comm=comm)
    m["wall_time"] = wall
    cm.report(
        f"friction patch {args.dim}D, deformable master, {args.integration}, {n} sliding "
        f"steps: {m['slave_nodes_on']} slave nodes in contact, {comm.size} rank(s)",
        [
            (
                "press step max |p_N/p0 - 1|, |p_T|/p0",
                f"{m['press_p_err']:.2e}, {m['press_q']:.2e}",
            ),
            ("max |p_N/p0 - 1| (all, wholly covered)", f"{m['p_err']:.3e}, {m['p_err_inner']:.3e}"),
            (
                "max ||p_T|/(mu p0) - 1| (all, wholly covered)",
                f"{m['q_err']:.3e}, {m['q_err_inner']:.3e}",
            ),
            ("slave node states", str(m["states"])),
            (
                "contact force errors (n, t)",
                f"{m['force_normal_err']:.2e}, {m['force_tangential_err']:.2e}",
            ),
            ("Newton iterations", str(m["newton_iterations"])),
            ("Uzawa rounds", str(m["uzawa_rounds"])),
            ("wall time", f"{wall:.2f} s"),
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_friction_patch")
