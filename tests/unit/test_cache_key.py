"""The compiled-model cache key is a hash of what determines the generated code: the canonical
model (not what a model file adds to it), the component classes' and the compiler's sources."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from porthamiltonian import io
from porthamiltonian.compiler import cache

ROOT = Path(__file__).resolve().parents[2]
MSD = (ROOT / "models" / "mass_spring_damper.toml").read_text()


def key(text: str) -> str:
    return cache.model_key(io.loads(text, source="msd.toml"))


def test_file_metadata_does_not_change_the_key():
    """Description, [simulation] defaults, further [model] keys, parameter docs: same key."""
    assert "description" in MSD and "[simulation]" in MSD
    edited = (MSD.replace("t_end = 20.0", "t_end = 3.0")
              .replace('[model]\n', '[model]\nauthor = "someone"\n')
              .replace('doc = "spring stiffness"', 'doc = "the spring\'s stiffness"'))
    edited = edited.replace(edited.split("description = ", 1)[1].split("\n", 1)[0],
                            '"another description"')
    assert edited != MSD
    assert key(edited) == key(MSD)


def test_what_the_generated_code_depends_on_changes_the_key():
    base = key(MSD)
    assert key(MSD.replace("k = { value = 4.0,", "k = { value = 5.0,")) != base  # a default
    assert key(MSD.replace('resistance = "c"', 'resistance = "2*c"')) != base    # a law
    assert key(MSD.replace('name = "mass_spring_damper"', 'name = "msd2"')) != base


def _key_in(tree: Path) -> str:
    code = ("from porthamiltonian import io; from porthamiltonian.compiler import cache; "
            "print(cache.model_key(io.load('mass_spring_damper')))")
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tree, capture_output=True,
                         text=True, timeout=120, check=True)
    return out.stdout.strip()


def test_editing_the_command_line_keeps_the_key_editing_a_component_does_not(tmp_path):
    tree = tmp_path / "tree"
    shutil.copytree(ROOT / "porthamiltonian", tree / "porthamiltonian",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "models", tree / "models")
    before = _key_in(tree)
    cli = tree / "porthamiltonian" / "interfaces" / "cli.py"
    cli.write_text(cli.read_text().replace('"""Command line', '"""The command line', 1))
    assert _key_in(tree) == before
    elements = tree / "porthamiltonian" / "modeling" / "elements.py"
    elements.write_text(elements.read_text().replace('"""Capacitive storage', '"""Capacitor', 1))
    assert _key_in(tree) != before
