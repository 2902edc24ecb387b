"""``python -m bipedsim.cli``: the ``bipedsim`` command."""

from __future__ import annotations

import sys

from bipedsim.cli import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
