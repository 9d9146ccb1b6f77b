"""Shared fixtures: small gmsh meshes with named groups, written by rank 0 only."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from _mpi_guard import pytest_runtest_logfinish, pytest_runtest_makereport  # noqa: F401
from mpi4py import MPI

#: The serial pass's longest test files, longest first (seconds of their tests in the
#: serial pass of scripts/test.sh beside two helpers' runs, session 56: 632, 153, 111,
#: 90, 69, 49, 38 of 1347 in all; test_kernels_segment.py, 67 s then, left the list in
#: session 59, when its finite differences took 75 s → 13 s beside one helper's runs).
#: Under pytest-xdist (``--dist loadfile``: a file
#: per worker at a time, handed out in collection order) they are collected first, the
#: other files after them in their usual order: a long file handed out late kept one
#: worker busy while the other had nothing left (longest first: the pass ends nearer
#: half the tests' time). Serially and under mpirun the order is the usual one.
XDIST_LONG_FILES = (
    "test_cli.py",
    "test_friction.py",
    "test_bench_scripts.py",
    "test_friction_demos.py",
    "test_uzawa.py",
    "test_bench.py",
    "test_demos.py",
)


def mpi_marks(size: int) -> str:
    """The marker expression of a run on ``size`` > 1 ranks (pyproject's markers): on 2
    ranks every ``mpi`` and ``mpi2`` test, on 3 or more the ``mpi`` tests but the
    ``mpi_not3`` ones (``mpi_not1`` ones too: they leave the serial pass of
    scripts/test.sh only). The other tests are serial: run on every rank, each would repeat
    the serial run in the ranks' shared folders (a test's output lock then fails it)."""
    return "mpi or mpi2" if size == 2 else "mpi and not mpi_not3"


def pytest_configure(config):
    """Under mpirun, a command line without ``-m`` selects :func:`mpi_marks`' tests
    (scripts/test.sh's MPI passes rely on it), and rank 0 says so on stderr."""
    size = MPI.COMM_WORLD.size
    if size > 1 and not config.option.markexpr:
        config.option.markexpr = mpi_marks(size)
        if MPI.COMM_WORLD.rank == 0:
            sys.stderr.write(
                f"conftest: {size} ranks, the tests selected by -m {mpi_marks(size)!r} "
                "(give -m to choose others)\n"
            )


def pytest_collection_modifyitems(config, items):
    """Under a pytest-xdist worker, the files of XDIST_LONG_FILES first, longest first
    (a stable sort: the tests of a file keep their order and stay together)."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    rank = {name: i for i, name in enumerate(XDIST_LONG_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def write_block_msh(
    path: Path,
    dim: int,
    n: int = 3,
    quads: bool = False,
    order: int = 1,
    size=(2.0, 1.0, 1.0),
    version=4.1,
):
    """Block [0,Lx]×[0,Ly](×[0,Lz]) with groups body; left/right (x), bottom/top (y), back/front (z)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("block")
    occ = gmsh.model.occ
    if dim == 2:
        occ.addRectangle(0, 0, 0, size[0], size[1])
    else:
        occ.addBox(0, 0, 0, *size)
    occ.synchronize()
    body = gmsh.model.getEntities(dim)
    gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, [e[1] for e in body]), "body")
    names = {
        (0, 0): "left",
        (0, 1): "right",
        (1, 0): "bottom",
        (1, 1): "top",
        (2, 0): "back",
        (2, 1): "front",
    }
    groups = {}
    for d, tag in gmsh.model.getEntities(dim - 1):
        c = gmsh.model.occ.getCenterOfMass(d, tag)
        for axis in range(dim):
            for side in (0, 1):
                if abs(c[axis] - side * size[axis]) < 1e-9:
                    groups.setdefault(names[(axis, side)], []).append(tag)
    for name, tags in groups.items():
        gmsh.model.setPhysicalName(dim - 1, gmsh.model.addPhysicalGroup(dim - 1, tags), name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", min(size[:dim]) / n)
    if quads:
        for d in range(1, dim + 1):
            for _, tag in gmsh.model.getEntities(d):
                if d == 1:
                    gmsh.model.mesh.setTransfiniteCurve(tag, n + 1)
                elif d == 2:
                    gmsh.model.mesh.setTransfiniteSurface(tag)
                    gmsh.model.mesh.setRecombine(2, tag)
                else:
                    gmsh.model.mesh.setTransfiniteVolume(tag)
    gmsh.model.mesh.generate(dim)
    gmsh.model.mesh.setOrder(order)
    gmsh.option.setNumber("Mesh.MshFileVersion", version)
    gmsh.write(str(path))
    gmsh.finalize()


def patch_press_scene(steps: int = 1, lower_bottom=(0, 1), friction: float = 0.0) -> dict:
    """A coarse patch2d press scene (small strain, linear elastic, E = 100, ν = 0.3):
    the upper top pressed down 0.01 over t ∈ [0, 1] in ``steps`` steps, the lower bottom
    held in the components ``lower_bottom``, one pair upper_bottom:lower_top with
    coefficient ``friction`` (0: frictionless)."""
    held = list(lower_bottom)
    return {
        "title": "press",
        "kinematics": "small",
        "mesh": {"generator": "patch2d", "params": {"n_lower": 2, "n_upper": 3, "n_y": 1}},
        "material": [
            {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3}
            for r in ("lower", "upper")
        ],
        "contact": [{"slave": "upper_bottom", "master": "lower_top", "friction": friction}],
        "dirichlet": [
            {
                "boundary": "lower_bottom",
                "components": held,
                "path": [[0.0] * (1 + len(held)), [1.0] + [0.0] * len(held)],
            },
            {"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.01]]},
        ],
        "steps": {"n": steps},
    }


@pytest.fixture
def shared_tmp(tmp_path_factory):
    """A temporary directory with the same path on every rank (collective)."""
    comm = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("shared")) if comm.rank == 0 else None
    path = comm.bcast(path, root=0)
    return Path(path)


def written_once(path: Path, write, *args) -> Path:
    """``path``, written by ``write(path, *args)`` on rank 0 of COMM_WORLD where it does
    not exist yet (a mesh shared by the tests of a module), then a barrier (collective)."""
    if MPI.COMM_WORLD.rank == 0 and not path.exists():
        write(path, *args)
    MPI.COMM_WORLD.barrier()
    return path


@pytest.fixture
def block_msh(shared_tmp):
    """Factory: block_msh(dim, n, quads, order) -> path of a .msh file (collective)."""

    def make(dim, n=3, quads=False, order=1, size=(2.0, 1.0, 1.0), version=4.1):
        path = shared_tmp / f"block{dim}_{n}_{int(quads)}_{order}_{version}.msh"
        return written_once(path, write_block_msh, dim, n, quads, order, size, version)

    return make


os.environ.setdefault("OMP_NUM_THREADS", "1")


@pytest.fixture
def exact_contact_tangent(monkeypatch):
    """The exact contact tangent at every Jacobian: the finite-difference configurations
    press the bodies up to 0.125 h_I into each other (a few active nodes on coarse meshes),
    where DEEP_PENETRATION_TOL would leave the geometric part of the tangent out
    (tested on its own in test_contact_jacobian.py), raised to inf where it is defined,
    tangential.py, which both stages read (the normal tangent in contact.py; the
    friction's slip-reversal rule and ``deep_start``). Only for tests that compare the
    tangent with finite differences, marked one by one: it changes the Newton tangent, so
    a scene run under it does not test the shipped solver (never a module-wide
    ``pytestmark``)."""
    import numpy as np

    from dolfinx_mortar import tangential

    monkeypatch.setattr(tangential, "DEEP_PENETRATION_TOL", np.inf)


def stick_only_scene(gap0: float = 0.005) -> dict:
    """hertz2d (h_contact 0.2) without its symmetry condition, frictional (μ = 0.3): the
    block clamped at its bottom, the cylinder's top pushed down 0.1 in u_y only over
    t ∈ [0, 1], its u_x free, in 2 steps to t = 2, the cylinder ``gap0`` above the block at
    t = 0. Only stick can hold the cylinder along x, and with gap0 = 0.005 (25 × the
    0.01 h of HISTORY_GAP_TOL) no slave node touches at t = 0: the step where the
    contact forms has no friction, and the cylinder slid 3.0 along x off the contact
    (the run ended "ok" with no node in contact)."""
    return {
        "title": "hertz2d free in x, held by stick only",
        "kinematics": "small",
        "mesh": {
            "generator": "hertz2d",
            "params": {"h_contact": 0.2, "gap0": gap0, "h_far": 4.0},
        },
        "material": [
            {"region": r, "model": "linear-elastic", "E": 200.0, "nu": 0.3}
            for r in ("cylinder", "block")
        ],
        "contact": [{"slave": "cylinder_surface", "master": "block_top", "friction": 0.3}],
        "dirichlet": [
            {"boundary": "block_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
            {
                "boundary": "cylinder_top",
                "components": [1],
                "path": [[0.0, 0.0], [1.0, -0.1], [2.0, -0.1]],
            },
        ],
        "steps": {"t_end": 2.0, "n": 2},
    }


#: A process that holds an output directory's lock as a run does (flock on the lock file,
#: its record written), prints "locked" and sleeps; argv: the lock file's path.
_LOCK_HOLDER = """
import fcntl, json, os, socket, sys, time
fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT, 0o644)
fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
record = {"host": socket.gethostname(), "pid": os.getpid(), "since": "2026-01-01 00:00:00 UTC"}
os.write(fd, json.dumps(record).encode())
print("locked", flush=True)
time.sleep(120)
"""


def hold_lock(out_dir: Path):
    """Start a process that holds the lock of ``out_dir`` (created where missing) as
    another run would; returns its Popen once it holds it (kill it when done: the kernel
    then releases the lock and leaves the file, as after a killed run)."""
    import subprocess
    import sys

    from dolfinx_mortar.output import LOCK_NAME

    Path(out_dir).mkdir(parents=True, exist_ok=True)
    holder = subprocess.Popen(
        [sys.executable, "-c", _LOCK_HOLDER, str(Path(out_dir) / LOCK_NAME)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert holder.stdout.readline() == "locked\n"
    return holder
