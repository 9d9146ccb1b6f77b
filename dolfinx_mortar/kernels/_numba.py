"""numba, imported where a host program's warning filters cannot stop it, with the
package's kernels cached against all of their sources (local).

Every module of the package that compiles with numba imports it from here.

**Warnings.** numba imports llvmlite, whose import (Debian bookworm's llvmlite 0.39 on
Python 3.11) calls the deprecated ``importlib.resources.path`` and warns
``DeprecationWarning: path is deprecated. Use files() instead``. Python ignores that
warning by default, but a host program that turns warnings into errors
(``warnings.simplefilter("error")``, ``python -W error``, a test suite's
``filterwarnings = error``) got it raised from its first ``run``, with a traceback from
deep inside the contact module (numba is imported on first use, when the host's filters
are in force). Here DeprecationWarnings (and pending ones) are ignored during numba's
import only; the host's filters are put back after it (``warnings.catch_warnings``), and
nothing is ignored where numba was imported already.

**Cache freshness.** numba's on-disk cache (``cache=True``) keys a kernel's entries to
the modification time and size of the kernel's own source file only, but a cached kernel
holds the machine code of every kernel it calls, from other files too, as they were when
it was compiled. After an edit of ``gap.py`` (an update of the package, a developer's
change), ``friction.py``'s cached kernels still loaded with the old ``gap`` code inside,
and where the old and the new code of one callee met in a process under the same symbol
name (numba names a function by its qualified name, a per-process counter and its
argument types), the first one loaded served both: a session-62 edit of ``mortar.py``
left ``node_rows`` (a kernel since removed) returning wrong rows after a frictional run
in the same process, until the cache was deleted. Here every function of this package's
files is cached against :func:`source_stamp`, the times and sizes of all the kernel
sources (:data:`KERNEL_DIR`'s ``*.py``) and of its own file: an edit of any kernel
source makes every kernel compile afresh, once. numba's own choice of the cache folder
is kept (the locators below wrap numba's ``NUMBA_CACHE_DIR``, in-tree ``__pycache__``
and user-wide ones); other packages' functions are cached as numba does it.

**Processes that compile at once.** numba names a function's data files 1, 2, … in the
order its signatures are saved, each process choosing the first number that its read
of the index leaves free. Two processes that save two different signatures of one
function at the same time (the ranks of a first job on a cold cache, the two runs of
``scripts/warm_cache.sh``; 9 of the package's functions are cached with 2 to 4
signatures: readonly or writable arrays, literal or variable integers) both choose
number 1, and the index of one can end up naming the data of the other: a later process
then loads, for one signature, the machine code compiled for another (numba issue
#10128 reports segmentation faults from such a race). Here the data file of each of the
package's cache entries is named by a hash of its key (:class:`KeyedIndexDataCacheFile`),
so different signatures never share a file; a race can still drop an entry from the
index (the last writer's index wins), which costs one more compile and nothing else.

**Functions of other processes.** numba tells apart the functions it compiles by a
number in their symbol names, counted from 1 in every process
(``numba.core.bytecode.FunctionIdentity``): two functions made from one definition with
other captured variables, such as the closures numba builds its sorts and argsorts from,
can have the same name and argument types but other code, and differ by that number
only. Cached machine code keeps the numbers of the process
that compiled it, so a process that loads kernels compiled by two processes can meet two
different functions under one symbol name, and the JIT links every call to the first one
loaded. Seen in session 68 (and on the tree before it): with ``search._box_sweep``
(an argsort of float64 and a sort of int64) cached by one process and
``mortar.jacobian_terms`` (its ``compress_rows``, an argsort of int64) by another, a
third process that loaded both in that order got nonsense dof indices from
``jacobian_terms`` (which two functions met was not traced further), and the run stopped in an MPI call (``expecting 1 items, got 2``);
the sequence: one kernel test, then a demo twice, all on one empty cache. Here each
process counts from a random start of its own (:func:`_separate_function_numbers`), so
numbers from different processes do not meet; within a process they are unique as
before. The numbers only name functions; nothing else reads them.
"""

import hashlib
import itertools
import os
import warnings
from pathlib import Path

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    warnings.simplefilter("ignore", PendingDeprecationWarning)
    import numba
    from numba.core import bytecode, caching

__all__ = ["KERNEL_DIR", "KeyedIndexDataCacheFile", "numba", "source_stamp"]

#: The folder of the kernel sources, whose compiled code kernels share.
KERNEL_DIR = Path(__file__).resolve().parent
#: The package's folder: its files' numba functions are cached against source_stamp.
_PACKAGE_DIR = KERNEL_DIR.parent
#: The cache folders of the package's functions (as their locators give them): their
#: data files are named by key (:class:`KeyedIndexDataCacheFile`)
PACKAGE_CACHE_PATHS: set[str] = set()


def source_stamp(py_file: str | os.PathLike) -> tuple:
    """The freshness stamp of the numba cache entries of a function defined in
    ``py_file`` (local): ((name, mtime, size), …) of every ``*.py`` in
    :data:`KERNEL_DIR` and of ``py_file``, sorted by path. Any change of one of these
    files gives another stamp, and numba then compiles the function again instead of
    loading it (its index holds the stamp it was saved with)."""
    files = set(KERNEL_DIR.glob("*.py"))
    files.add(Path(py_file).resolve())
    stamp = []
    for path in sorted(files):
        st = path.stat()
        stamp.append((str(path.relative_to(_PACKAGE_DIR)), st.st_mtime, st.st_size))
    return tuple(stamp)


def _in_package(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(_PACKAGE_DIR)
    except OSError:
        return False


def _package_locator(base: type) -> type:
    """numba's cache locator ``base`` for this package's functions only, with
    :func:`source_stamp` as their freshness stamp."""

    class PackageLocator(base):
        @classmethod
        def from_function(cls, py_func, py_file):
            if not _in_package(py_file):
                return None
            locator = super().from_function(py_func, py_file)
            if locator is not None:
                PACKAGE_CACHE_PATHS.add(locator.get_cache_path())
            return locator

        def get_source_stamp(self):
            return source_stamp(self._py_file)

    PackageLocator.__name__ = PackageLocator.__qualname__ = f"Package{base.__name__}"
    return PackageLocator


class KeyedIndexDataCacheFile(caching.IndexDataCacheFile):
    """numba's index and data files of one function's cache, with the data file of each
    entry of the package's functions named ``<base>.<hash of its key>.nbc`` instead of
    ``<base>.<n>.nbc`` (local). numba creates these objects for every cached function;
    one whose folder is not one of :data:`PACKAGE_CACHE_PATHS` (another package's)
    saves as numba does. The index format is numba's, and so is loading: an index
    written by numba itself (numbered names) is read as it is."""

    def __init__(self, cache_path, filename_base, source_stamp):
        super().__init__(cache_path, filename_base, source_stamp)
        #: whether the data files are named by key (a folder of the package's functions)
        self.keyed = cache_path in PACKAGE_CACHE_PATHS
        self._base = filename_base

    def keyed_name(self, key) -> str:
        """The data file's name of the entry ``key`` (numba's (signature, target,
        bytecode hashes)); numba's type names are unique, so the key's repr is too."""
        digest = hashlib.sha256(repr(key).encode()).hexdigest()[:24]
        return f"{self._base}.{digest}.nbc"

    def save(self, key, data):
        """numba's save, the data file named by key where :attr:`keyed`, and written
        (whole: ``os.replace``) before the index takes the entry, so that a process that
        finds the entry finds this data (numba writes the index first: a process reading
        in between loaded the file left under that name by an earlier compile, as after
        an edit that kept a function's bytecode)."""
        if not self.keyed:
            return super().save(key, data)
        name = self.keyed_name(key)
        self._save_data(name, data)
        overloads = self._load_index()
        if overloads.get(key) != name:
            overloads[key] = name
            self._save_index(overloads)


def _install() -> None:
    """Put the package's locators first in numba's list (once a process): numba tries
    them in order, and the first that accepts a function (its file in this package and
    its folder writable) caches it."""
    classes = caching.CacheImpl._locator_classes
    if any(getattr(c, "_dolfinx_mortar", False) for c in classes):
        return
    bases = [
        c
        for c in (
            caching._UserProvidedCacheLocator,
            caching._InTreeCacheLocator,
            caching._UserWideCacheLocator,
        )
        if c in classes
    ]
    ours = [_package_locator(c) for c in bases]
    for c in ours:
        c._dolfinx_mortar = True
    classes[:0] = ours
    # numba's Cache looks the class up when it creates a function's cache
    caching.IndexDataCacheFile = KeyedIndexDataCacheFile


def _separate_function_numbers() -> None:
    """Start this process's function numbers (numba's ``FunctionIdentity`` counter, see
    the module's docstring) at a random multiple of 2^20 below 2^60, once a process
    (local): two of a thousand processes that each number a million functions overlap with
    a chance of about 10^-6. Numbers given before keep theirs."""
    if getattr(bytecode.FunctionIdentity._unique_ids, "_dolfinx_mortar", False):
        return
    start = max(1, int.from_bytes(os.urandom(5), "little")) << 20
    bytecode.FunctionIdentity._unique_ids = _Counter(start)


class _Counter:
    """itertools.count(start), marked as :func:`_separate_function_numbers`' counter."""

    _dolfinx_mortar = True

    def __init__(self, start: int):
        self._it = itertools.count(start)

    def __iter__(self):
        return self

    def __next__(self) -> int:
        return next(self._it)


_install()
_separate_function_numbers()
