"""Profile verbs: `profile-params` (a gauge file's Sh/Sd/qR), `import-reference`,
`export-profile` and `agreement` (wayside against handheld, also `rr --against references`)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.config import add_settings_arguments, settings_from_args
from backend.services.agreement_report import agreement_csv, agreement_pdf
from backend.services.profile_export import FORMATS, export_profile
from backend.services.references import add_reference, agreement, decode_profile_file
from db.engine import make_engine, make_session_factory, upgrade_database
from db.models import PassWheel, Wheel
from pipeline.profile.exchange import handheld_parameters, read_profile_text


@contextmanager
def database_session(args: argparse.Namespace) -> Iterator[Session]:
    """A session on the settings' database (migrated first), disposed of afterwards."""
    engine = make_engine(settings_from_args(args).resolved_database_url)
    try:
        upgrade_database(engine)
        with make_session_factory(engine)() as session:
            yield session
    finally:
        engine.dispose()


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 4)


def _profile_params(args: argparse.Namespace) -> int:
    path: Path = args.file
    profile = read_profile_text(
        decode_profile_file(path.read_bytes(), path.name), suffix=path.suffix
    )
    result = handheld_parameters(profile)
    p = result.parameters
    document = {
        "file": str(path),
        "flange_height_mm": _round(p.flange_height_mm),
        "flange_thickness_mm": _round(p.flange_thickness_mm),
        "flange_thickness_10_mm": _round(p.flange_thickness_10_mm),
        "qr_mm": _round(p.qr_mm),
        "quality": result.quality,
        "quality_reason": result.reason,
        "points": int(profile.x_mm.size),
        "reversed": profile.reversed,
        "x_offset_mm": _round(profile.x_offset_mm),
        "z_offset_mm": _round(profile.z_offset_mm),
        "instrument": {
            "name": profile.instrument,
            "measured_on": profile.measured_on,
            "flange_height_mm": profile.instrument_flange_height_mm,
            "flange_thickness_mm": profile.instrument_flange_thickness_mm,
            "qr_mm": profile.instrument_qr_mm,
        },
    }
    if args.json:
        sys.stdout.write(json.dumps(document, indent=2) + "\n")
    else:
        sys.stdout.write(
            f"Sh {p.flange_height_mm:.2f} mm · Sd {p.flange_thickness_mm:.2f} mm · "
            f"Sd EN {p.flange_thickness_10_mm:.2f} mm · qR {p.qr_mm:.2f} mm ({result.quality})\n"
        )
    return 0


def _import_reference(args: argparse.Namespace) -> int:
    path: Path = args.file
    with database_session(args) as session:
        wheel = session.get(Wheel, args.wheel)
        if wheel is None:
            raise ValueError(f"wheel {args.wheel} not found")
        row = add_reference(session, wheel, path.name, path.read_bytes(), args.measured_at, None)
        sys.stdout.write(
            f"reference {row.id} of wheel {wheel.id}: Sh {row.flange_height_mm:.2f} mm, "
            f"Sd {row.flange_thickness_mm:.2f} mm, Sd EN {row.flange_thickness_10_mm:.2f} mm, "
            f"qR {row.qr_mm:.2f} mm ({row.parameter_quality})\n"
        )
    return 0


def _export_profile(args: argparse.Namespace) -> int:
    with database_session(args) as session:
        pass_wheel = session.scalar(
            select(PassWheel).where(
                PassWheel.pass_id == args.pass_id, PassWheel.wheel_id == args.wheel
            )
        )
        if pass_wheel is None:
            raise ValueError(f"wheel {args.wheel} is not in pass {args.pass_id}")
        fmt = args.format or args.output.suffix.lstrip(".").lower()
        exported = export_profile(pass_wheel, args.method, fmt)
    args.output.write_bytes(exported.data)
    sys.stdout.write(f"{args.output}\n")
    return 0


def run_agreement(args: argparse.Namespace) -> int:
    """Wayside against handheld references: JSON (and optionally CSV and PDF) files."""
    with database_session(args) as session:
        table = agreement(session, args.pass_id or None)
    text = table.model_dump_json(indent=2) + "\n"
    if str(args.json) == "-":
        sys.stdout.write(text)
    else:
        Path(args.json).write_text(text, encoding="utf-8")
    if args.csv:
        args.csv.write_bytes(agreement_csv(table))
    if args.pdf:
        args.pdf.write_bytes(agreement_pdf(table))
    sys.stderr.write(f"{table.pairs} wheel result(s) paired with a handheld reference\n")
    return 0


def add_agreement_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of the agreement table (shared with `rr --against references`)."""
    parser.add_argument(
        "--pass-id", type=int, action="append", help="only this pass (repeatable; default all)"
    )
    parser.add_argument("--csv", type=Path, help="also write the table as CSV")
    parser.add_argument("--pdf", type=Path, help="also write the table as PDF")


def _aware(text: str) -> datetime:
    value = datetime.fromisoformat(text)
    if value.tzinfo is None:
        raise argparse.ArgumentTypeError("needs a time zone, e.g. 2026-11-30T08:00:00Z")
    return value


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the profile verbs."""
    params = subparsers.add_parser(
        "profile-params", help="Sh, Sd and qR of a handheld-gauge file (.whl, .prr, .csv)"
    )
    params.add_argument("file", type=Path, metavar="FILE")
    params.add_argument("--json", action="store_true", help="print a JSON object")
    params.set_defaults(func=_profile_params)

    imported = subparsers.add_parser(
        "import-reference", help="store a handheld-gauge profile as a wheel's reference"
    )
    imported.add_argument("file", type=Path, metavar="FILE")
    imported.add_argument("--wheel", type=int, required=True, help="wheel id")
    imported.add_argument("--measured-at", type=_aware, help="ISO 8601 with zone (default now)")
    add_settings_arguments(imported)
    imported.set_defaults(func=_import_reference)

    export = subparsers.add_parser(
        "export-profile", help="write a wheel's fused profile as CSV, DXF or MiniProf .whl"
    )
    export.add_argument("--pass", dest="pass_id", type=int, required=True, help="pass id")
    export.add_argument("--wheel", type=int, required=True, help="wheel id")
    export.add_argument("--method", choices=("adaptive", "steger"), default="adaptive")
    export.add_argument("--format", choices=FORMATS, help="default: from the output's suffix")
    export.add_argument("-o", "--output", type=Path, required=True)
    add_settings_arguments(export)
    export.set_defaults(func=_export_profile)

    table = subparsers.add_parser(
        "agreement", help="wayside against handheld references (paper Table 2 form)"
    )
    table.add_argument("--json", required=True, metavar="OUT", help="output JSON, - for stdout")
    add_agreement_arguments(table)
    add_settings_arguments(table)
    table.set_defaults(func=run_agreement)
