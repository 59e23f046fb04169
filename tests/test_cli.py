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


def test_each_verb_is_registered_by_the_module_the_table_names() -> None:
    """`VERB_MODULES` lists exactly the verbs each module's `register` adds (a verb added to a
    module but not to the table would run only after `--help` loaded every module)."""
    import argparse
    import importlib

    from backend.cli import VERB_MODULES

    for module_name, verbs in VERB_MODULES.items():
        parser = argparse.ArgumentParser()
        subparsers = parser.add_subparsers(dest="verb")
        importlib.import_module(module_name).register(subparsers)
        assert tuple(subparsers.choices) == verbs, module_name


def test_a_verb_loads_only_its_own_module() -> None:
    probe = (
        "import sys; from backend.cli import build_parser; build_parser('agent');"
        "print(sorted(m for m in sys.modules if m.startswith('backend.cli.')))"
    )
    result = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "['backend.cli.agent']"
