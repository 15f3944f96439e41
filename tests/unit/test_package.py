"""The package carries its GLSL and its page (package data): a wheel install renders and
serves without the repository beside it."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "server" / "fogbank"


def test_the_wheel_holds_every_shader_and_page_file(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                    "-w", str(tmp_path), str(ROOT)], check=True, timeout=120)
    (wheel,) = tmp_path.glob("fogbank-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    want = {str(p.relative_to(PKG.parent)) for p in PKG.rglob("*")
            if p.is_file() and p.suffix in {".glsl", ".vert", ".frag", ".js", ".css", ".html", ".svg"}}
    assert len(want) > 40
    assert want - names == set()
