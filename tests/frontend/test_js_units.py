"""Run the front end's pure-module unit tests (node --test) as part of the Python suite."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


def test_frontend_lib_and_draw_modules_pass_their_unit_tests() -> None:
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: front-end unit tests (tests/frontend/*.mjs) NOT run")
    files = sorted(str(p) for p in HERE.glob("*.test.mjs"))
    result = subprocess.run(
        [node, "--test", *files], capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
