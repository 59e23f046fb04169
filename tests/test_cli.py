"""The `wheelscan` command line as a user runs it: one-line errors, never a traceback."""

from __future__ import annotations

import subprocess
import sys


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "backend.cli", *args], capture_output=True, text=True, check=False
    )


def test_help_lists_usage() -> None:
    result = run_cli("--help")
    assert result.returncode == 0
    assert "usage: wheelscan" in result.stdout


def test_unknown_verb_is_a_usage_error_without_traceback() -> None:
    result = run_cli("no-such-verb")
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
