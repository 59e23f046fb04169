"""The `wheelscan` command line: one sub-command module per verb group.

Each module in `VERB_MODULES` exposes `register(subparsers)`, which adds its verbs and sets
`func(args) -> int` on each. Errors a user can fix (`ValueError`, `OSError`) end as one line
on stderr and exit status 2, never a traceback. The verbs: README.md; where the CLI sits
among the layers: docs/service.md, "Layers".
"""

from __future__ import annotations

import argparse
import importlib
import sys

from backend.jobs.allocator import keep_freed_memory

VERB_MODULES: list[str] = [
    "backend.cli.extract",
    "backend.cli.agent",
    "backend.cli.measure",
    "backend.cli.conicity",
    "backend.cli.profiles",
    "backend.cli.worker",
    "backend.cli.serve",
    "backend.cli.backup",
    "backend.cli.retention",
]


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every registered verb."""
    parser = argparse.ArgumentParser(
        prog="wheelscan",
        description="Wayside railway wheel profile measurement with line-structured light.",
    )
    subparsers = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    for module_name in VERB_MODULES:
        importlib.import_module(module_name).register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the process exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    keep_freed_memory()  # every verb measures, serves or forks workers that do
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        sys.stderr.write("wheelscan: interrupted\n")
        return 130
    except (ValueError, OSError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        sys.stderr.write(f"wheelscan {args.verb}: error: {message}\n")
        return 2


if __name__ == "__main__":
    sys.exit(main())
