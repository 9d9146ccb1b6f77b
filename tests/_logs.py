"""The package's WARNING messages during a call, read on its own logger.

caplog's handler sits on the root logger and misses them after a test that changed the
level of the logger ``dolfinx_mortar`` (the command line's in-process tests do), so the
tests that assert a warning put a handler of their own on the package's logger."""

from __future__ import annotations

import logging


class _Warnings(logging.Handler):
    """The messages of the WARNING records it receives."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


def warnings_of(fn, *args):
    """``fn(*args)`` and the WARNING messages of the logger dolfinx_mortar meanwhile:
    (its result, list of str)."""
    logger, handler = logging.getLogger("dolfinx_mortar"), _Warnings()
    level = logger.level
    logger.setLevel(logging.WARNING)
    logger.addHandler(handler)
    try:
        return fn(*args), handler.messages
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
