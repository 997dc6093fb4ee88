"""``python -m porthamiltonian``: the ``porthamiltonian`` command."""
from .interfaces.cli import command

if __name__ == "__main__":
    raise SystemExit(command())
