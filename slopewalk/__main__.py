"""``python -m slopewalk``: the ``slopewalk`` command."""

import sys

from slopewalk.bench.cli import main

if __name__ == "__main__":
    sys.exit(main())
