"""``python -m magcilia``: the same command line as the ``magcilia`` script."""

from magcilia.cli import run

if __name__ == "__main__":
    run()
