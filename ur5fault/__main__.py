"""``python -m ur5fault``: the ``ur5fault`` command (:func:`ur5fault.cli.main`)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
