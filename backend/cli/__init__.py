"""The `wheelscan` command line: one sub-command module per verb group.

Each module in `VERB_MODULES` exposes `register(subparsers)`, which adds its verbs and sets
`func(args) -> int` on each. A command imports only the module of its own verb (`VERBS`), so
`wheelscan agent` does not load the web service, the PDF renderer and the pipeline's kernels
(about 3 s of CPU per start); `--help` and an unknown verb load them all. Errors a user can fix
(`ValueError`, `OSError`) end as one line on stderr and exit status 2, never a traceback. The
verbs: README.md; where the CLI sits among the layers: docs/service.md, "Layers".
"""

from __future__ import annotations

import argparse
import importlib
import sys

from backend.jobs.allocator import keep_freed_memory

VERB_MODULES: dict[str, tuple[str, ...]] = {
    "backend.cli.extract": ("extract",),
    "backend.cli.agent": ("agent", "agent-replay"),
    "backend.cli.measure": ("synth-pass", "measure", "calibrate", "synth-calibration", "rr"),
    "backend.cli.conicity": ("conicity",),
    "backend.cli.profiles": ("profile-params", "import-reference", "export-profile", "agreement"),
    "backend.cli.worker": ("worker",),
    "backend.cli.migrate": ("migrate",),
    "backend.cli.serve": ("serve",),
    "backend.cli.token": ("token",),
    "backend.cli.demo": ("run-demo",),
    "backend.cli.backup": ("backup", "restore"),
    "backend.cli.retention": ("retention",),
}
"""Each verb module and the verbs it registers (checked against `register` by the tests)."""

VERBS: dict[str, str] = {verb: module for module, verbs in VERB_MODULES.items() for verb in verbs}
"""The module that registers each verb."""


def build_parser(verb: str | None = None) -> argparse.ArgumentParser:
    """Build the argument parser: with `verb`'s module only, or (None) with every verb."""
    parser = argparse.ArgumentParser(
        prog="wheelscan",
        description="Wayside railway wheel profile measurement with line-structured light.",
    )
    subparsers = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    modules = [VERBS[verb]] if verb in VERBS else list(VERB_MODULES)
    for module_name in modules:
        importlib.import_module(module_name).register(subparsers)
    return parser


def _verb_of(argv: list[str]) -> str | None:
    """The verb `argv` names (its first word), or None for `--help`, nothing or an unknown one."""
    if not argv or argv[0].startswith("-"):
        return None
    return argv[0] if argv[0] in VERBS else None


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the process exit status."""
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser(_verb_of(argv))
    args = parser.parse_args(argv)
    keep_freed_memory()  # every verb measures, serves or forks workers that do
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt as stopped:  # Ctrl-C, or the agent's SIGTERM (`Terminated`)
        sys.stderr.write(f"wheelscan: {getattr(stopped, 'message', 'interrupted')}\n")
        return int(getattr(stopped, "exit_status", 130))
    except (ValueError, OSError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        sys.stderr.write(f"wheelscan {args.verb}: error: {message}\n")
        return 2


if __name__ == "__main__":
    sys.exit(main())
