"""numba, imported where a host program's warning filters cannot stop it (local).

Every module of the package that compiles with numba imports it from here. numba imports
llvmlite, whose import (Debian bookworm's llvmlite 0.39 on Python 3.11) calls the
deprecated ``importlib.resources.path`` and warns ``DeprecationWarning: path is
deprecated. Use files() instead``. Python ignores that warning by default, but a host
program that turns warnings into errors (``warnings.simplefilter("error")``, ``python -W
error``, a test suite's ``filterwarnings = error``) got it raised from its first ``run``,
with a traceback from deep inside the contact module (numba is imported on first use,
when the host's filters are in force). Here DeprecationWarnings (and pending ones) are
ignored during numba's import only; the host's filters are put back after it
(``warnings.catch_warnings``), and nothing is ignored where numba was imported already.
"""

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    warnings.simplefilter("ignore", PendingDeprecationWarning)
    import numba

__all__ = ["numba"]
