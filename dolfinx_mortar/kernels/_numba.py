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
holds the machine code of every kernel it calls, from other files too, as they were
when it was compiled. After an edit of ``gap.py`` (an update of the package, a developer's
change), ``friction.py``'s cached kernels still loaded with the old ``gap`` code inside,
and where the old and the new code of one callee met in a process under the same symbol
name (numba names a function by its qualified name, a per-process counter and its
argument types), the first one loaded served both: a session-62 edit of ``mortar.py``
left ``node_rows`` returning wrong rows after a frictional run in the same process,
until the cache was deleted. Here every function of this package's files is cached
against :func:`source_stamp`, the times and sizes of all the kernel sources
(:data:`KERNEL_DIR`'s ``*.py``) and of its own file: an edit of any kernel source makes
every kernel compile afresh, once. numba's own choice of the cache folder is kept (the
locators below wrap numba's ``NUMBA_CACHE_DIR``, in-tree ``__pycache__`` and user-wide
ones); other packages' functions are cached as numba does it.
"""

import os
import warnings
from pathlib import Path

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    warnings.simplefilter("ignore", PendingDeprecationWarning)
    import numba
    from numba.core import caching

__all__ = ["KERNEL_DIR", "numba", "source_stamp"]

#: The folder of the kernel sources, whose compiled code kernels share.
KERNEL_DIR = Path(__file__).resolve().parent
#: The package's folder: its files' numba functions are cached against source_stamp.
_PACKAGE_DIR = KERNEL_DIR.parent


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
            return super().from_function(py_func, py_file)

        def get_source_stamp(self):
            return source_stamp(self._py_file)

    PackageLocator.__name__ = PackageLocator.__qualname__ = f"Package{base.__name__}"
    return PackageLocator


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


_install()
