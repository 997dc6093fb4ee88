"""``python -m walker_library``: the ``walker`` command."""
from .cli import command

if __name__ == "__main__":
    raise SystemExit(command())
