"""Headless Chromium for the tests that render pages (the report, the 3D viewer).

The browser is found on PATH. Without one the tests skip with a one-line reason, unless ``CI``
is set: CI installs Chromium (.ci/run), so there a missing browser fails. WebGL comes from
SwiftShader, Chromium's software renderer (``--enable-unsafe-swiftshader``: it is not used for
WebGL by default any more), so no GPU is needed.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from PIL import Image

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader", "--enable-logging=stderr", "--v=0",
         "--virtual-time-budget=5000"]


def chromium() -> str:
    """The browser's executable, or a skip (a failure under CI) saying how to install one."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        message = ("needs a headless browser: install Chromium (Debian/Ubuntu: apt-get install -y "
                   "chromium)")
        if os.environ.get("CI"):
            pytest.fail(f"{message}; CI installs it (.ci/run)")
        pytest.skip(message)
    return exe


def run(args: list[str]) -> subprocess.CompletedProcess:
    """Chromium with :data:`FLAGS`, a fresh profile and ``args``."""
    with tempfile.TemporaryDirectory() as profile:
        return subprocess.run([chromium(), *FLAGS, f"--user-data-dir={profile}", *args],
                              capture_output=True, text=True, timeout=120, check=False)


def render(path: Path) -> tuple[str, list[str]]:
    """(DOM after load, console lines) of a local page."""
    proc = run(["--dump-dom", path.resolve().as_uri()])
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    return proc.stdout, console


def console_errors(console: list[str]) -> list[str]:
    """The console lines that report errors (uncaught exceptions, failed loads)."""
    return [c for c in console if "Uncaught" in c or "rror" in c]


def screenshot(url: str, width: int, height: int, out: Path) -> Image.Image:
    """A screenshot of ``url`` in a window of ``width`` × ``height`` CSS px."""
    run([f"--window-size={width},{height}", "--hide-scrollbars", f"--screenshot={out}", url])
    assert out.is_file(), "Chromium wrote no screenshot"
    return Image.open(out).convert("RGB")
