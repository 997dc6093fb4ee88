"""README's "What is here" tree against the source tree: it names every module and sub-package of
porthamiltonian/ and walker_library/, and nothing that does not exist."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _tree() -> dict[str, set[str]]:
    """The names the README tree lists under each package (``x.py`` and ``sub/``)."""
    text = (ROOT / "README.md").read_text()
    block = text.split("## What is here", 1)[1].split("```", 2)[1]
    listed: dict[str, set[str]] = {}
    package = None
    for line in block.splitlines():
        top = re.match(r"(\w+)/\s", line)
        if top:
            package = top.group(1)
            listed[package] = set()
            continue
        if package is None:
            continue
        listed[package] |= set(re.findall(r"\b(\w+\.py|\w+/)", line))
    return listed


def _actual(package: str) -> set[str]:
    base = ROOT / package
    return ({p.name for p in base.glob("*.py") if p.name not in ("__init__.py", "__main__.py")}
            | {f"{p.name}/" for p in base.iterdir() if (p / "__init__.py").is_file()})


def test_the_readme_tree_lists_every_module_and_nothing_else():
    listed = _tree()
    for package in ("porthamiltonian", "walker_library"):
        modules = {n for n in listed[package] if n.endswith(("/", ".py"))}
        actual = _actual(package)
        assert actual - modules == set(), f"{package}: not in README: {sorted(actual - modules)}"
        sub_modules = {n for n in modules - actual if n.endswith(".py")}
        known = {p.name for p in (ROOT / package).rglob("*.py")}
        assert sub_modules <= known, f"{package}: README names {sorted(sub_modules - known)}"
