"""Work-precision of the three codes on the peers' problems A (Hertz) and B (Cattaneo–Mindlin).

Reads ``results_hertz2d.csv`` and ``results_cattaneo2d.csv`` of a copy of the peers
harness (``../shared/peers``, after ``run_all.py --codes mortar ...``) and draws, per
problem, the L2 error (A: pressure; B: tangential traction) against the solve time, one
curve per code (ours: the runs with ``--ranks`` ranks, small kinematics). Kratos's errors
are taken in its nominal-traction conversion (``*_nom`` columns), which is what our
nominal pressures compare with (BENCHMARKS.md §3).

Run::

    /usr/bin/python3 bench/plot_peers.py /tmp/peers --out docs/figures/peers_work_precision.png
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

PROBLEMS = {
    "A": ("results_hertz2d.csv", "l2_rel_p", "Hertz (A): L2 error of p"),
    "B": ("results_cattaneo2d.csv", "l2_rel_q", "Cattaneo–Mindlin (B): L2 error of q"),
}
STYLE = {"kratos": "s--", "getfem": "^:", "mortar": "o-"}
LABEL = {"kratos": "Kratos (mortar ALM)", "getfem": "GetFEM (ALM)", "mortar": "dolfinx_mortar"}


def curves(path: Path, metric: str, ranks: int) -> dict[str, list[tuple[float, float, int]]]:
    """(solve time, error, level) per code, sorted by level."""
    out: dict[str, list[tuple[float, float, int]]] = {}
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            if r.get("status") != "ok":
                continue
            code = r["code"]
            if code == "mortar" and (
                int(r.get("ranks") or 1) != ranks or r.get("kinematics", "small") != "small"
            ):
                continue
            value = r.get(f"{metric}_nom") if code == "kratos" and r.get(f"{metric}_nom") else None
            err = float(value if value is not None else r[metric])
            out.setdefault(code, []).append((float(r["t_solve"]), err, int(r["level"])))
    return {c: sorted(v, key=lambda x: x[2]) for c, v in out.items()}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("peers", type=Path, help="the peers harness directory (a copy)")
    ap.add_argument("--out", type=Path, default=Path("bench/out/peers_work_precision.png"))
    ap.add_argument("--ranks", type=int, default=1, help="our runs with this many ranks [1]")
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, (name, metric, title) in zip(axes, PROBLEMS.values(), strict=True):
        path = args.peers / name
        if not path.is_file():
            ax.set_title(f"{title}: {name} not found")
            continue
        for code, pts in curves(path, metric, args.ranks).items():
            t, e, lv = zip(*pts, strict=True)
            ax.loglog(t, e, STYLE.get(code, "o-"), label=LABEL.get(code, code))
            for ti, ei, li in pts:
                ax.annotate(
                    f"L{li}", (ti, ei), fontsize=7, xytext=(3, 3), textcoords="offset points"
                )
        ax.set_xlabel("solve time (s)")
        ax.set_ylabel("relative L2 error")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    plt.close(fig)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
