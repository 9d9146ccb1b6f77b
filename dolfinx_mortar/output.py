"""Everything a run writes (SCENES.md, "What a run writes"); the library writes nowhere else.

- ``summary.json`` (rank 0), rewritten atomically after every converged step, so
  a run that fails or is killed keeps every finished step and says where it stopped;
- ``contact_<SLAVE>_<step>.csv`` (rank 0), one row per slave node, ordered by
  reference coordinates, identical for any number of ranks;
- ``fields.xdmf`` (+ ``.h5``): displacement and the contact fields (pressure,
  gap, state; tangential traction and slip where friction is modelled) as
  nodal functions of the mesh's degree, zero away from slave surfaces.
"""

from __future__ import annotations

import json
import logging
import os
import re
from pathlib import Path

import numpy as np
from dolfinx import fem, io

log = logging.getLogger(__name__)

CSV_FIELDS_2D = ["x", "y", "X", "Y", "p_N", "p_T0", "gap", "slip", "state"]
CSV_FIELDS_3D = ["x", "y", "z", "X", "Y", "Z", "p_N", "p_T0", "p_T1", "gap", "slip", "state"]


def _atomic_write_json(path: Path, data) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "w") as f:
        json.dump(data, f, indent=1, default=_json_default)
    os.replace(tmp, path)


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj)}")


def write_contact_csv(path: Path, table: np.ndarray, gdim: int) -> None:
    """Write the slave-node table (rows = nodes, columns = CSV_FIELDS_{2D,3D}) sorted by reference coordinates."""
    header = CSV_FIELDS_2D if gdim == 2 else CSV_FIELDS_3D
    if table.size:
        order = np.lexsort(tuple(np.round(table[:, k], 12) for k in reversed(range(gdim))))
        table = table[order]
    fmt = ["%.17g"] * (len(header) - 1) + ["%d"]
    np.savetxt(
        path,
        table.reshape(-1, len(header)),
        delimiter=",",
        header=",".join(header),
        comments="",
        fmt=fmt,
    )


class OutputWriter:
    """Writes a run's files into ``out_dir`` (collective: every rank calls every method).

    Parameters
    ----------
    out_dir: output directory (created on the first write, never before).
    problem: the ContactProblem (its ``u``, ``V`` and contact terms are read).
    summary: the run-level part of summary.json (scene, modelled, ranks, dofs).
    fields: the output field names requested by the scene.
    """

    def __init__(self, out_dir: Path, problem, summary: dict, fields=()):
        self.out_dir = Path(out_dir)
        self.problem = problem
        self.comm = problem.comm
        self.summary = dict(summary)
        self.summary.setdefault("steps", [])
        self.summary["status"] = "running"
        self.summary["error"] = None
        self.fields = tuple(fields)
        self._xdmf = None
        self._contact_functions = {}

    def start(self) -> None:
        """Create the directory, remove the contact CSV files a previous run of the same
        pairs left there (a shorter run would otherwise leave stale later steps), and
        write the initial state (step 0)."""
        if self.comm.rank == 0:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            for term in self.problem.contacts:
                pattern = re.compile(rf"contact_{re.escape(term.slave_name)}_\d+\.csv$")
                for f in self.out_dir.glob(f"contact_{term.slave_name}_*.csv"):
                    if pattern.match(f.name):
                        f.unlink()
        self.comm.barrier()
        p = self.problem
        self._xdmf = io.XDMFFile(self.comm, str(self.out_dir / "fields.xdmf"), "w")
        self._xdmf.write_mesh(p.mesh)
        if p.contacts:
            Q = fem.FunctionSpace(p.mesh, ("CG", p.degree))
            names = {
                "contact_pressure": "contact_pressure",
                "gap": "gap",
                "contact_state": "contact_state",
            }
            if any(getattr(c, "frictional", False) for c in p.contacts):
                names.update({"tangential_traction": "tangential_traction_norm", "slip": "slip"})
            for key, name in names.items():
                if key in self.fields or key == "slip":
                    self._contact_functions[key] = fem.Function(Q, name=name)
        self.write_step(0, 0.0, None)

    def write_step(self, step: int, t: float, record: dict | None) -> None:
        """Write the state of converged step ``step`` at time t; ``record`` joins summary.json."""
        p = self.problem
        if "displacement" in self.fields:
            self._xdmf.write_function(p.u, t)
        for term in p.contacts:
            table = term.node_table()  # gathered on rank 0
            if self.comm.rank == 0:
                write_contact_csv(
                    self.out_dir / f"contact_{term.slave_name}_{step}.csv", table, p.gdim
                )
        if self._contact_functions:
            for f in self._contact_functions.values():
                f.x.array[:] = 0.0
            for term in p.contacts:
                term.fill_fields(self._contact_functions)
            for f in self._contact_functions.values():
                f.x.scatter_forward()
                self._xdmf.write_function(f, t)
        if record is not None:
            self.summary["steps"].append(record)
        self._flush()

    def finish(self, status: str, error: str | None = None, timings: dict | None = None) -> None:
        """Close the files and write the final summary (status "ok" or "failed")."""
        self.summary["status"] = status
        self.summary["error"] = error
        if timings is not None:
            self.summary["timings"] = timings
        if self._xdmf is not None:
            self._xdmf.close()
            self._xdmf = None
        self._flush()

    def _flush(self) -> None:
        if self.comm.rank == 0:
            _atomic_write_json(self.out_dir / "summary.json", self.summary)
