"""The numba cache of the package's kernels is keyed to all of the kernel sources
(kernels/_numba.py): a cached kernel holds the code of the kernels it calls, so an edit
of one kernel file must make every kernel compile again, not only those of that file."""

import importlib
import os

import pytest

from dolfinx_mortar.kernels import _numba
from dolfinx_mortar.kernels._numba import numba

#: every module with numba kernels (``kernels.shape`` the module: the package exports a
#: function of that name too)
MODULES = [
    importlib.import_module(f"dolfinx_mortar.{name}")
    for name in ("kernels.friction", "kernels.gap", "kernels.mortar", "kernels.segment",
                 "kernels.shape", "search")
]  # fmt: skip


def _dispatchers(module):
    return [
        f
        for name, f in sorted(vars(module).items())
        if isinstance(f, numba.core.registry.CPUDispatcher) and f.__module__ == module.__name__
    ]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__.rsplit(".", 1)[1])
def test_every_kernel_is_cached_against_every_kernel_source(module):
    kernels = _dispatchers(module)
    assert kernels, module.__name__
    sources = {p.name for p in _numba.KERNEL_DIR.glob("*.py")}
    for f in kernels:
        cache = f._cache
        assert type(cache._impl.locator).__name__.startswith("Package"), f.__name__
        stamp = cache._cache_file._source_stamp
        assert stamp == _numba.source_stamp(module.__file__), f.__name__
        names = {os.path.basename(entry[0]) for entry in stamp}
        assert sources <= names, (f.__name__, sources - names)
        assert os.path.basename(module.__file__) in names
        # the data files of each entry named by its key (a race-free name)
        assert isinstance(cache._cache_file, _numba.KeyedIndexDataCacheFile), f.__name__
        assert cache._cache_file.keyed, f.__name__


def test_the_stamp_changes_with_any_kernel_source(tmp_path, monkeypatch):
    """Touching another kernel file (a newer mtime, as an edit or an update of the
    package gives it) changes the stamp of a kernel in this file; a file outside the
    package is left to numba's own locators."""
    pkg = tmp_path / "pkg"
    kdir = pkg / "kernels"
    kdir.mkdir(parents=True)
    for name in ("a.py", "b.py"):
        (kdir / name).write_text("x = 1\n")
    monkeypatch.setattr(_numba, "KERNEL_DIR", kdir)
    monkeypatch.setattr(_numba, "_PACKAGE_DIR", pkg)
    before = _numba.source_stamp(kdir / "a.py")
    st = os.stat(kdir / "b.py")
    os.utime(kdir / "b.py", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    after = _numba.source_stamp(kdir / "a.py")
    assert before != after
    assert [e[0] for e in after] == ["kernels/a.py", "kernels/b.py"]
    (kdir / "b.py").write_text("x = 22\n")  # the same time, another size
    os.utime(kdir / "b.py", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert _numba.source_stamp(kdir / "a.py") != after
    outside = tmp_path / "host.py"
    outside.write_text("def f():\n    return 1\n")
    assert not _numba._in_package(str(outside))
    assert _numba._in_package(str(kdir / "a.py"))


def test_the_package_locators_are_installed_once():
    from numba.core import caching

    _numba._install()
    ours = [c for c in caching.CacheImpl._locator_classes if getattr(c, "_dolfinx_mortar", 0)]
    assert len(ours) == 3
    assert caching.CacheImpl._locator_classes[: len(ours)] == ours


def _race(cache_path, stamp, keyed):
    """Two processes save two signatures A and B of one function into an empty index at
    once: both read the index before either writes it; B's index goes in first, then A's
    index and data, then B's data (numba's save writes the index, then the data). Returns
    what a later process loads for A and for B."""

    cls = _numba.KeyedIndexDataCacheFile if keyed else _numba.KeyedIndexDataCacheFile.__base__
    p_a, p_b = (cls(str(cache_path), "k.f-1.py311", stamp) for _ in range(2))
    assert getattr(p_a, "keyed", False) == keyed
    for p in (p_a, p_b):
        p._load_index = lambda: {}  # each read the index while it was empty
    deferred = []
    save_b = p_b._save_data
    p_b._save_data = lambda name, data: deferred.append((name, data))
    p_b.save(("B",), "code for B")  # B's index, its data held back
    p_a.save(("A",), "code for A")  # A's index (over B's) and data
    save_b(*deferred.pop())  # B's data, last
    later = cls(str(cache_path), "k.f-1.py311", stamp)
    return later.load(("A",)), later.load(("B",))


def test_two_processes_saving_two_signatures_at_once_keep_each_its_code(tmp_path, monkeypatch):
    """numba names the data files 1, 2, … by the first number free in the index each
    process read: two processes that save different signatures of one function at once
    both take number 1, and A's index entry can name B's code (numba's class: a later
    process loads "code for B" for A). The package's KeyedIndexDataCacheFile names each
    data file by its key: A loads A's code, B is not in the index (the last index
    written wins), so B compiles again; nothing loads another signature's code."""
    stamp = (("kernels/f.py", 1.0, 10),)
    stock, keyed = tmp_path / "stock", tmp_path / "keyed"
    for d in (stock, keyed):
        d.mkdir()
    assert _race(stock, stamp, keyed=False) == ("code for B", None)  # numba's hazard
    monkeypatch.setattr(_numba, "PACKAGE_CACHE_PATHS", {str(keyed)})
    assert _race(keyed, stamp, keyed=True) == ("code for A", None)
    names = sorted(p.name for p in keyed.iterdir())
    assert len(names) == 3 and names[-1] == "k.f-1.py311.nbi", names  # A's, B's, index
    assert _numba.KeyedIndexDataCacheFile(str(tmp_path), "x", stamp).keyed is False


def test_a_keyed_entry_is_indexed_after_its_data_is_written(tmp_path, monkeypatch):
    """KeyedIndexDataCacheFile.save writes the data file before the index names it, so a
    process that reads the new entry finds its data (numba writes the index first; a
    reader in between loaded whatever an earlier compile had left under the name)."""
    stamp = (("kernels/f.py", 1.0, 10),)
    monkeypatch.setattr(_numba, "PACKAGE_CACHE_PATHS", {str(tmp_path)})
    cache = _numba.KeyedIndexDataCacheFile(str(tmp_path), "k.f-1.py311", stamp)
    name = cache.keyed_name(("A",))
    save_index = cache._save_index
    seen = []

    def checked(overloads):
        seen.append((tmp_path / name).is_file())
        save_index(overloads)

    cache._save_index = checked
    cache.save(("A",), "code for A")
    cache.save(("A",), "code for A, again")  # the entry is indexed: no index write
    assert seen == [True]
    assert _numba.KeyedIndexDataCacheFile(str(tmp_path), "k.f-1.py311", stamp).load(("A",)) == (
        "code for A, again"
    )


def test_each_process_numbers_its_functions_apart(tmp_path):
    """numba names the functions it compiles with a number counted in each process, and
    cached code keeps the numbers of the process that compiled it: two processes' closures
    of one definition (numba's sort and argsort) could meet under one symbol name in a
    third process that loads both (session 68: nonsense dof indices from jacobian_terms
    after search._box_sweep's code from another process). Importing the package's numba
    starts each process's numbers at a random multiple of 2^20 (kernels/_numba.py): two
    processes start apart, the numbers still count up within a process, and a cached
    function compiles, saves and loads as before."""
    import subprocess
    import sys

    script = tmp_path / "function_numbers.py"
    script.write_text(
        "import numpy as np\n"
        "from dolfinx_mortar.kernels._numba import numba\n"
        "from numba.core import bytecode\n"
        "@numba.njit(cache=True)\n"
        "def order(a):\n"
        "    return np.argsort(a)\n"
        "a = np.array([3, 1, 2, 0])\n"
        "assert list(order(a)) == [3, 1, 2, 0]\n"
        "c = bytecode.FunctionIdentity._unique_ids\n"
        "print(next(c), next(c))\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    starts = []
    for _ in range(2):  # the first compiles and saves, the second loads
        out = subprocess.run(
            [sys.executable, str(script)], env=env, capture_output=True, text=True, check=True
        )
        first, second = map(int, out.stdout.split())
        assert second == first + 1 and first >= 1 << 20, out.stdout
        starts.append(first)
    assert starts[0] // (1 << 20) != starts[1] // (1 << 20), starts
    assert list((tmp_path / "cache").rglob("*.nbi")), "nothing cached"
