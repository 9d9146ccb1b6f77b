"""``python3 -m dolfinx_mortar`` is the ``dolfinx-mortar`` command."""

import sys

from .cli import main

sys.exit(main())
