"""3D Coulomb friction along a turning path: a block pressed, then its top led around a circle or a square.

The upper patch3d block (hexahedra, linear elastic, E = 100, ν = 0, small strain) is
pressed with a traction p0 on ``upper_top`` in the first step (t ≤ 1); then the top's
x, y follow the path: a circle x = r(cos θ − 1), y = r sin θ in ``n`` steps per loop, or
a square of side ``r`` with ``n``/4 steps per side. The lower block is held on every
boundary (rigid). Shear tractions on the upper block's sides, equal to the exact
tangential traction, make the stress state uniform, so that the discrete answer is
exact: every node slips with |τ| = μ p0, and the slip direction d_k of step k is the
fixed point of the backward-Euler step Δs_k = Δu_k − c (d_k − d_{k−1}),
d_k = Δs_k / |Δs_k|, c = μ p0 H / G (the elastic shear offset of the top turning with
d). The work of the drive Σ R_top·Δu_top is then μ F_N Σ d_k·Δu_k.

Printed per step: |F_T|/(μ F_N) − 1, the largest |τ|/(μ p_N) − 1 over the nodes, the
angle of the friction force from the chord Δu_k and from d_k, the largest angle of a
node's traction from d_k, the Newton iterations; then the work identity. The runs are
deterministic (single runs suffice). From the repository root (BENCHMARKS §54):

    /usr/bin/python3 bench/bench_turning_slip.py                      # circle r=0.3, N=16
    /usr/bin/python3 bench/bench_turning_slip.py --path square --r 0.4 --n 16
    mpirun -n 2 /usr/bin/python3 bench/bench_turning_slip.py          # the same figures

``tests/test_friction_paths.py`` runs a small version of the circle (its own reference).
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np
from mpi4py import MPI

L, H = 1.0, 0.5
PAIR = "upper_bottom:lower_top"


def top_path(path: str = "circle", n: int = 16, r: float = 0.3) -> np.ndarray:
    """(n + 1, 2) positions (x, y) of the top after each slide step, from (0, 0)."""
    if path == "circle":
        th = np.linspace(0.0, 2.0 * np.pi, n + 1)
        return np.c_[r * (np.cos(th) - 1.0), r * np.sin(th)]
    if path != "square" or n % 4:
        raise ValueError(f"path: 'circle', or 'square' with n a multiple of 4, not {path!r}, {n}")
    corners = np.array([[0.0, 0.0], [r, 0.0], [r, r], [0.0, r], [0.0, 0.0]])
    s = np.arange(1, n // 4 + 1) / (n // 4)
    steps = [a + (b - a) * s[:, None] for a, b in zip(corners[:-1], corners[1:], strict=True)]
    return np.vstack([corners[:1], *steps])


def slip_directions(P: np.ndarray, c: float) -> np.ndarray:
    """(n, 2) exact unit slip directions d_k of the steps of the path ``P`` (n + 1, 2):
    the fixed point of Δs = Δu_k − c (d_k − d_{k−1}), d_k = Δs/|Δs|, d_{−1} = 0 (no
    tangential traction after the press)."""
    d, prev = [], np.zeros(2)
    for du in np.diff(P, axis=0):
        dk = du / np.linalg.norm(du)
        for _ in range(200):
            ds = du - c * (dk - prev)
            dk, old = ds / np.linalg.norm(ds), dk
            if np.linalg.norm(dk - old) < 1e-16:
                break
        d.append(dk)
        prev = dk
    return np.array(d)


def scene(
    P: np.ndarray,
    *,
    mu: float = 0.3,
    p0: float = 2.0,
    E: float = 100.0,
    n_upper: int = 4,
    n_lower: int | None = None,
    n_y: int = 2,
    integration: str = "segment",
    frame: str = "slave",
) -> dict:
    """The scene dictionary (``parse_scene``) for the top path ``P`` (n + 1, 2): t = 1 the
    press, t = 1 + k the k-th slide step. The side tractions are −μ p0 d_k
    (:func:`slip_directions`, ν = 0: G = E/2)."""
    d = slip_directions(P, mu * p0 * H / (E / 2.0))
    q = -mu * p0 * d  # traction of the master on the slave after each step
    margin = float(np.ptp(P, axis=0).max()) + 0.2
    if n_lower is None:
        n_lower = max(4, round((L + 2 * margin) / (L / n_upper)))
    n = len(P) - 1
    times = [1.0 + k for k in range(1, n + 1)]
    top = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]] + [
        [t, *p] for t, p in zip(times, P[1:].tolist(), strict=True)
    ]

    def side(sign, comp):
        return [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]] + [
            [t, 0.0, 0.0, sign * float(v)] for t, v in zip(times, q[:, comp], strict=True)
        ]

    held = [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
    lower = ("bottom", "top", "left", "right", "front", "back")
    return {
        "title": f"turning slip, {n} steps",
        "kinematics": "small",
        "mesh": {
            "generator": "patch3d",
            "params": dict(L=L, H=H, n_lower=n_lower, n_upper=n_upper, n_y=n_y, margin=margin),
        },
        "material": [
            {"region": b, "model": "linear-elastic", "E": E, "nu": 0.0} for b in ("upper", "lower")
        ],
        "contact": [
            {
                "slave": "upper_bottom",
                "master": "lower_top",
                "friction": mu,
                "integration": integration,
                "tangential_frame": frame,
                "uzawa_tol": 1e-9,
                "uzawa_max": 40,
            }
        ],
        "dirichlet": [{"boundary": f"lower_{b}", "path": held} for b in lower]
        + [{"boundary": "upper_top", "components": [0, 1], "path": top}],
        "traction": [{"boundary": "upper_top", "path": [[0.0, 0, 0, 0.0], [1.0, 0, 0, -p0]]}]
        + [
            {"boundary": f"upper_{b}", "path": side(s, c)}
            for b, s, c in (("left", 1, 0), ("right", -1, 0), ("front", 1, 1), ("back", -1, 1))
        ],
        "steps": {"t_end": float(n + 1), "n": n + 1, "max_cutbacks": 4},
        "solver": {"rtol": 1e-10, "atol": 1e-12, "max_it": 25},
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def node_tractions(out_dir, step: int, comm) -> np.ndarray:
    """(n, 3) p_N and the x, y components of τ of the slave nodes after converged step
    ``step`` (1 = the press), from rank 0's CSV (collective). The slave's outward normal
    is −z, so the CSV's frame is t0 = x, t1 = n × t0 = −y."""
    tab = None
    if comm.rank == 0:
        f = f"{out_dir}/contact_upper_bottom_{step}.csv"
        t = np.genfromtxt(f, delimiter=",", names=True)
        tab = np.c_[t["p_N"], t["p_T0"], -t["p_T1"]]
    return comm.bcast(tab, root=0)


def angle(a, b) -> float:
    """Signed angle (rad) from the 2-vector b to a."""
    return float(np.arctan2(b[0] * a[1] - b[1] * a[0], a @ b))


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--path", choices=["circle", "square"], default="circle")
    ap.add_argument("--r", type=float, default=0.3, help="circle radius or square side")
    ap.add_argument("--n", type=int, default=16, help="slide steps per loop")
    ap.add_argument("--n-upper", type=int, default=4, help="slave facets per side")
    ap.add_argument("--integration", default="segment")
    ap.add_argument("--frame", default="slave")
    a = ap.parse_args(argv)
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    mu, p0 = 0.3, 2.0
    P = top_path(a.path, a.n, a.r)
    d = slip_directions(P, mu * p0 * H / 50.0)
    data = scene(P, mu=mu, p0=p0, n_upper=a.n_upper, integration=a.integration, frame=a.frame)
    with tempfile.TemporaryDirectory() as tmp:
        out = comm.bcast(tmp, root=0)
        s = run(parse_scene(data, out), comm, out_dir=out)
        if s["status"] != "ok":
            raise SystemExit(f"run failed: {s['error']}")
        steps = s["steps"]
        assert [st["t"] for st in steps] == [float(k) for k in range(1, len(P) + 1)]
        rows, W, Wd, chords = [], 0.0, 0.0, 0.0
        for k, st in enumerate(steps[1:]):
            F = np.array(st["contact_force"][PAIR])
            tab = node_tractions(out, k + 2, comm)
            du = P[k + 1] - P[k]
            W += np.array(st["reactions"]["upper_top"][:2]) @ du
            Wd += mu * F[2] * d[k] @ du
            chords += np.linalg.norm(du)
            tau = np.linalg.norm(tab[:, 1:], axis=1)
            rows.append(
                {
                    "step": k + 1,
                    "FT": np.hypot(*F[:2]) / (mu * F[2]) - 1.0,
                    "tau": float(np.abs(tau / (mu * tab[:, 0]) - 1.0).max()),
                    "chord_deg": np.degrees(angle(-F[:2], du)),
                    "exact_deg": np.degrees(angle(-F[:2], d[k])),
                    "nodes_deg": max(abs(np.degrees(angle(-t, d[k]))) for t in tab[:, 1:]),
                    "newton": st["newton_iterations"],
                }
            )
    FN = steps[-1]["contact_force"][PAIR][2]
    res = {"rows": rows, "W": W, "W_exact": Wd, "W_chord": mu * FN * chords}
    if comm.rank == 0:
        print(f"{a.path} r = {a.r}, {a.n} steps, {a.integration}, {comm.size} rank(s)")
        print("step  |F_T|/μF_N−1  max|τ|/μp−1  ∠(−F_T, Δu)°  ∠(−F_T, d_k)°  max node ∠°  Newton")
        for r in rows:
            print(
                f"{r['step']:4d}  {r['FT']: .2e}  {r['tau']:.2e}  {r['chord_deg']: 10.5f}"
                f"  {r['exact_deg']: .2e}  {r['nodes_deg']:.2e}  {r['newton']}"
            )
        print(
            f"W = Σ R_top·Δu = {W:.12g}; μF_N Σ d_k·Δu_k = {Wd:.12g} (rel {W / Wd - 1:.1e});"
            f" W/(μF_N Σ|Δu|) − 1 = {W / res['W_chord'] - 1:.3e}"
        )
    return res


if __name__ == "__main__":
    main()
