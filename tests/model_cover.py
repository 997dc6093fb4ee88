"""The shipped models as a test parametrization: a covering set in the README's command, the
rest marked ``breadth`` (run by ``.ci/run``'s second pass, tests/conftest.py).

A check made on every shipped model (its pH form, its power balance, its file's round trip)
repeats, model after model, the same code on the same kinds of components. The README's command
makes it on a set of models that together hold every *feature* of the shipped files
(:func:`features`: each component type, and each of its fields; a multibody's formulation,
dimension and joint types; each section of the file; the simulation method), the smallest such
set found greedily (the model holding the most features not yet held first, ties by name: the
same set on every machine); ``.ci/run`` makes it on all of them. A model file added with a
feature no other has joins the set by itself.
"""
from __future__ import annotations

import functools
import tomllib
from pathlib import Path
from typing import Any

import pytest

from porthamiltonian import io

MODELS_DIR = Path(io.__file__).resolve().parents[2] / "models"


def features(name: str) -> frozenset[str]:
    """What the shipped model ``name``'s file holds, as names (see the module docstring; read
    as TOML: the test collection does not build the models)."""
    data = tomllib.loads((MODELS_DIR / f"{name}.toml").read_text())
    found = {f"section:{section}" for section in data}
    method = data.get("simulation", {}).get("method")
    if method is not None:
        found.add(f"method:{method}")
    for component in data.get("components", {}).values():
        kind = str(component.get("type"))
        found.add(kind)
        found.update(f"{kind}.{field}" for field in component)
        if kind == "Multibody":
            found.add(f"Multibody:{component.get('formulation', 'auto')}")
            found.add(f"Multibody:{len(component.get('gravity', ()))}d")
            found.update(f"joint:{joint.get('type')}"
                         for joint in component.get("joints", {}).values())
    return frozenset(found)


@functools.cache
def covering_models() -> tuple[str, ...]:
    """The shipped models that together hold every feature, found greedily (module docstring)."""
    held = {path.stem: features(path.stem) for path in sorted(MODELS_DIR.glob("*.toml"))}
    left = set().union(*held.values())
    chosen: list[str] = []
    while left:
        best = max(held, key=lambda name: (len(held[name] & left), [-ord(c) for c in name]))
        chosen.append(best)
        left -= held[best]
    return tuple(chosen)


def every_model() -> list[Any]:
    """Every model of ``io.available_models()`` as a ``pytest.param``, the shipped ones outside
    :func:`covering_models` marked ``breadth``."""
    cover = set(covering_models())
    shipped = {path.stem for path in MODELS_DIR.glob("*.toml")}
    return [pytest.param(name, marks=pytest.mark.breadth if name in shipped - cover else ())
            for name in io.available_models()]
