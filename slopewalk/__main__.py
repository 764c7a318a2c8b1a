"""``python -m slopewalk``: the ``slopewalk`` command."""

from slopewalk.bench.cli import command

if __name__ == "__main__":
    command()
