"""Faults survived and backups restored: runs the fault tests (tests/faults: the server
SIGKILLed mid-upload, mid-measurement and mid-report, PostgreSQL restarted under load, a
nearly full disk) and the backup → restore tests (tests/backend/test_backup*.py), and
reports each test's outcome and time. A passed test found nothing lost, nothing
half-written and the state the user sees clear (see the tests for what each checks).

Run alone with `python -m benchmarks.run hardening`.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SUITES = {
    "faults": ["tests/faults"],
    "backup and restore": ["tests/backend/test_backup.py", "tests/backend/test_backup_errors.py"],
}
_OUTCOME = re.compile(r"^(?P<outcome>PASSED|FAILED|SKIPPED|ERROR) (?P<test>.+?)(?: - .*)?$", re.M)
_DURATION = re.compile(r"^(?P<seconds>[\d.]+)s call\s+(?P<test>.+?)$", re.M)


def _run_suite(paths: list[str]) -> tuple[list[tuple[str, str, float]], float]:
    started_s = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "pytest", *paths, "-q", "-rA", "-p", "no:warnings",
         "--durations=0", "--durations-min=0"],
        capture_output=True, text=True, cwd=ROOT, check=False,
    )  # fmt: skip
    elapsed_s = time.perf_counter() - started_s
    durations = {m["test"]: float(m["seconds"]) for m in _DURATION.finditer(result.stdout)}
    outcomes = [
        (m["test"], m["outcome"], durations.get(m["test"], float("nan")))
        for m in _OUTCOME.finditer(result.stdout)
    ]
    return outcomes, elapsed_s


def run() -> str:
    """Markdown section: each fault and backup test, its outcome and its time."""
    lines = ["## Faults survived, backups restored (tests/faults, tests/backend/test_backup*)", ""]
    for name, paths in SUITES.items():
        outcomes, elapsed_s = _run_suite(paths)
        passed = sum(outcome == "PASSED" for _, outcome, _ in outcomes)
        lines += [
            f"### {name}: {passed} of {len(outcomes)} passed in {elapsed_s:.0f} s",
            "",
            "| test | outcome | s |",
            "|---|---|---|",
            *(f"| `{test}` | {outcome} | {seconds:.1f} |" for test, outcome, seconds in outcomes),
            "",
        ]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.stdout.write(run() + "\n")
