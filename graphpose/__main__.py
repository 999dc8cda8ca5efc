"""``python -m graphpose``: the command line (see :mod:`graphpose.cli`)."""

from .cli import entry

if __name__ == "__main__":
    entry()
