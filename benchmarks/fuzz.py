"""API fuzzing figures: runs tests/backend/test_fuzz_api.py (schemathesis against the served
OpenAPI document, SQLite and PostgreSQL, five kinds of caller) and reports the cases each
run sent and its outcome: a passed run had no server error and no response off its schema.

Run alone with `python -m benchmarks.fuzz` (prints the Markdown section).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TEST = "tests/backend/test_fuzz_api.py"
_COUNTS = re.compile(
    r"fuzzed as (?P<caller>[\w ]+?) on (?P<db>\w+): (?P<ops>\d+) operations, (?P<cases>\d+) cases, "
    r"(?P<server>\d+) server errors, (?P<conformance>\d+) conformance failures"
)
_OUTCOME = re.compile(r"^(?P<outcome>PASSED|FAILED) \S+\[(?P<db>\w+)-(?P<caller>[\w ]+)\]", re.M)


def run() -> str:
    """Run the fuzz test once; the Markdown section with its figures."""
    load_before = os.getloadavg()[0]
    started_s = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "pytest", TEST, "-k", "every_operation", "-rA", "-p", "no:warnings",
         "-o", "log_cli=true", "--log-cli-level=INFO"],
        capture_output=True, text=True, cwd=ROOT, check=False,
    )  # fmt: skip
    elapsed_s = time.perf_counter() - started_s
    counts = {(m["db"], m["caller"]): m for m in _COUNTS.finditer(result.stdout)}
    outcomes = {(m["db"], m["caller"]): m["outcome"] for m in _OUTCOME.finditer(result.stdout)}
    rows = [
        f"| {db} | {caller} | {m['ops']} | {m['cases']} | {m['server']} | {m['conformance']} | "
        f"{outcomes.get((db, caller), 'not run')} |"
        for (db, caller), m in counts.items()
    ]
    total = sum(int(m["cases"]) for m in counts.values())
    failed = sum(outcome == "FAILED" for outcome in outcomes.values())
    return "\n".join(
        [
            f"## API fuzzing ({TEST})",
            "",
            f"{total} generated requests in {elapsed_s:.0f} s ({len(counts)} runs, "
            f"{failed} failed): valid and invalid data for every operation of /openapi.json, "
            "and valid data on a stored pass; checks: no 5xx, documented status, content "
            "type, headers and body schema, invalid data refused. 1-min load average "
            f"{load_before:.1f} before, {os.getloadavg()[0]:.1f} at the end (2 cores shared).",
            "",
            "| database | caller | operations | cases | 5xx | conformance failures | result |",
            "|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


if __name__ == "__main__":
    sys.stdout.write(run() + "\n")
