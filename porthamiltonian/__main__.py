"""``python -m porthamiltonian``: the ``porthamiltonian`` command."""
from .interfaces.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
