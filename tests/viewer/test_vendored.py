"""The vendored three.js (porthamiltonian/viewer/vendor/three): the files are the ones its README
records (sha256, from the npm package three 0.185.1), the installed package carries them
(pyproject's package data), and a page carries them inline."""
from __future__ import annotations

import base64
import hashlib
import json
import re
import tomllib
from pathlib import Path

from porthamiltonian.interfaces import viewer
from porthamiltonian.interfaces.viewer.page import THREE_VERSION, assets

VENDOR = Path(viewer.__file__).parent / "vendor" / "three"
ROOT = Path(__file__).resolve().parents[2]


def test_the_files_are_the_recorded_release():
    readme = (VENDOR / "README.md").read_text()
    assert f"version **{THREE_VERSION}**" in readme
    rows = re.findall(r"\| `([\w.]+)` \| (\d+) \| `([0-9a-f]{64})` \|", readme)
    assert {name for name, _, _ in rows} == {"three.core.min.js", "three.module.min.js", "LICENSE"}
    for name, size, digest in rows:
        data = (VENDOR / name).read_bytes()
        assert len(data) == int(size) and hashlib.sha256(data).hexdigest() == digest, name
    assert "MIT License" in (VENDOR / "LICENSE").read_text()
    assert sorted(p.name for p in VENDOR.iterdir()) == ["LICENSE", "README.md",
                                                        "three.core.min.js", "three.module.min.js"]


def test_the_package_data_ships_them():
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    patterns = data["tool"]["setuptools"]["package-data"]["porthamiltonian"]
    package = ROOT / "porthamiltonian"
    shipped = {p.name for pattern in patterns for p in package.glob(pattern)}
    assert {"three.core.min.js", "three.module.min.js", "LICENSE", "README.md"} <= shipped


def test_a_page_carries_the_library_inline():
    html = assets()
    imports = json.loads(re.search(r'<script type="importmap">(.*?)</script>', html).group(1))
    module = base64.b64decode(imports["imports"]["three"].split(",", 1)[1]).decode()
    core = base64.b64decode(imports["imports"]["three/core"].split(",", 1)[1]).decode()
    assert core == (VENDOR / "three.core.min.js").read_text()
    assert module == (VENDOR / "three.module.min.js").read_text().replace(
        '"./three.core.min.js"', '"three/core"')
    assert "./three.core.min.js" not in module
