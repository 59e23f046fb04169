"""Run the benchmarks and write BENCHMARKS.md (`make bench`).

Each module in BENCH_MODULES exposes `run() -> str`, returning one Markdown section that
starts with a `## ` heading. `python -m benchmarks.run` runs them all and rewrites the file;
`python -m benchmarks.run extraction` runs the named modules only and replaces just their
sections, keeping the others as they were measured. Every section is stamped with the
machine and the date it was measured on.
"""

from __future__ import annotations

import importlib
import os
import platform
import re
import sys
from datetime import UTC, datetime
from pathlib import Path

BENCH_MODULES: list[str] = [
    "benchmarks.extraction",
    "benchmarks.camera_rate",
    "benchmarks.repeatability",
    "benchmarks.field_repeatability",
    "benchmarks.throughput",
    "benchmarks.agent",
    "benchmarks.load",
    "benchmarks.fuzz",
    "benchmarks.hardening",
    "benchmarks.reports",
    "benchmarks.review",
    "benchmarks.browser",
]

OUTPUT = Path(__file__).resolve().parent.parent / "BENCHMARKS.md"
_SECTION = re.compile(r"<!-- bench:(?P<name>[\w.]+) -->\n.*?<!-- /bench:(?P=name) -->\n", re.S)


def machine() -> str:
    """One line naming the CPU model, core count, RAM and Python of this machine."""
    model = "unknown CPU"
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    ram_gib = float("nan")
    meminfo = Path("/proc/meminfo")
    if meminfo.exists():
        for line in meminfo.read_text().splitlines():
            if line.startswith("MemTotal:"):
                ram_gib = int(line.split()[1]) / 2**20
                break
    return (
        f"{model}, {os.cpu_count()} cores, {ram_gib:.1f} GiB RAM, "
        f"Python {platform.python_version()} on {platform.system()}"
    )


def stamp() -> str:
    """`measured <UTC date and time> on <machine>` line for a section."""
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    return f"_Measured {when} on {machine()}._"


def run_section(module_name: str) -> str:
    """Run one benchmark module and wrap its section in markers."""
    body = importlib.import_module(module_name).run().strip()
    heading, _, rest = body.partition("\n")
    opening, closing = f"<!-- bench:{module_name} -->", f"<!-- /bench:{module_name} -->"
    return f"{opening}\n{heading}\n\n{stamp()}\n{rest}\n{closing}\n"


def header() -> str:
    return (
        "# wheelscan benchmarks\n\n"
        "Written by `make bench` (`python -m benchmarks.run`); do not edit by hand. "
        f"Last run: {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')} on {machine()}.\n\n"
    )


def main(argv: list[str] | None = None) -> int:
    """Run all (or the named) benchmark modules and update BENCHMARKS.md."""
    names = argv if argv is not None else sys.argv[1:]
    chosen = [m for m in BENCH_MODULES if not names or m.rsplit(".", 1)[-1] in names]
    unknown = set(names) - {m.rsplit(".", 1)[-1] for m in BENCH_MODULES}
    if unknown:
        sys.stderr.write(f"benchmarks: unknown module(s) {', '.join(sorted(unknown))}\n")
        return 2
    old = OUTPUT.read_text() if OUTPUT.exists() else ""
    sections = {m.group("name"): m.group(0) for m in _SECTION.finditer(old)}
    for module_name in chosen:
        sys.stderr.write(f"benchmark {module_name} …\n")
        sections[module_name] = run_section(module_name)
    ordered = [sections[m] for m in BENCH_MODULES if m in sections]
    ordered += [text for name, text in sections.items() if name not in BENCH_MODULES]
    OUTPUT.write_text(header() + "\n".join(ordered))
    sys.stderr.write(f"wrote {OUTPUT}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
