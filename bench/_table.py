"""Shared by the bench scripts: the CSV cell format and file of result rows."""

from __future__ import annotations

import csv
import math


def fmt(v) -> str:
    """A CSV cell: '' for None and NaN, 6 significant digits for floats."""
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.6g}"
    return v


def write_csv(rows, path, columns) -> None:
    """Write ``rows`` (dicts) with the given ``columns`` (missing keys: empty cells)."""
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns)
        w.writeheader()
        for r in rows:
            w.writerow({k: fmt(r.get(k)) for k in columns})
