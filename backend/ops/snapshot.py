"""The `wheelscan-backup/1` archive: what `wheelscan backup` writes and `wheelscan restore` reads.

One tar (optionally gzip-compressed), members in this order:

    manifest.json                   format, created_at, revisions, dialect, every member's sha256
    tables/<table>.jsonl            a header {"columns": [...]} then one JSON array per row
    blobs/<sha[:2]>/<sha><suffix>   the frame store's blobs, laid out as the store lays them

Rows are dialect-neutral: timestamps are ISO-8601 strings, JSON columns stay JSON and every
other value is a JSON scalar, so a SQLite backup restores into PostgreSQL and back. Tables
come in foreign-key order (parents first) and rows in primary-key order.
"""

from __future__ import annotations

import json
import os
from datetime import datetime
from pathlib import Path
from typing import Any, Final, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from sqlalchemy import Column, Connection, DateTime, MetaData, Table, inspect, text
from sqlalchemy.types import TypeDecorator

from db.models import Base

FORMAT: Final = "wheelscan-backup/1"
MANIFEST_MEMBER = "manifest.json"
MAX_MANIFEST_BYTES = 512 * 1024 * 1024
"""A manifest is about 150 bytes per blob; this allows millions and refuses a bomb."""

VERSION_TABLE = "alembic_version"
SHA256_REGEX = r"^[0-9a-f]{64}$"

BLOB_COLUMNS: dict[str, dict[str, str]] = {
    "frame": {"sha256": ".png"},
    "measurement_frame": {
        "artefact_sha256": ".npz",
        "mask_png_sha256": ".png",
        "sigma_png_sha256": ".png",
    },
}
"""Columns that name a blob in the frame store, with the blob's suffix."""

DIGEST_COLUMNS: frozenset[tuple[str, str]] = frozenset(
    {
        ("calibration", "sha256"),
        ("train_pass", "archive_sha256"),
        ("api_token", "token_sha256"),
        ("handheld_reference", "sha256"),
    }
)
"""sha256 columns that are digests of something not kept in the store."""


class BackupError(ValueError):
    """A backup or restore that cannot go on; the message is one line for the user."""


class TableEntry(BaseModel):
    """One table's member: its rows and the sha256 of its JSON-lines file."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(pattern=r"^[a-z_][a-z0-9_]{0,62}$")
    rows: int = Field(ge=0)
    bytes: int = Field(ge=0)
    sha256: str = Field(pattern=SHA256_REGEX)


class BlobEntry(BaseModel):
    """One blob of the frame store."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    sha256: str = Field(pattern=SHA256_REGEX)
    suffix: Literal[".png", ".npz"]
    bytes: int = Field(ge=0)


class Manifest(BaseModel):
    """What a backup holds; written first so a reader can check every member as it comes."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    format: Literal["wheelscan-backup/1"]
    created_at: datetime
    pipeline_version: str
    revision: str = Field(pattern=r"^[0-9A-Za-z_]{1,64}$", description="Alembic revision")
    dialect: str
    tables: list[TableEntry]
    blobs: list[BlobEntry]


def table_member(name: str) -> str:
    """The archive member holding the rows of table `name`."""
    return f"tables/{name}.jsonl"


def blob_member(sha256: str, suffix: str) -> str:
    """The archive member holding one blob (the store's own relative path)."""
    return f"blobs/{sha256[:2]}/{sha256}{suffix}"


def parse_manifest(data: bytes) -> Manifest:
    """The manifest of a backup, checked; BackupError naming the first problem."""
    try:
        document = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BackupError(f"not a wheelscan backup: manifest.json is not JSON ({exc})") from None
    found = document.get("format") if isinstance(document, dict) else None
    if found != FORMAT:
        raise BackupError(f"unsupported backup format {found!r}; this wheelscan reads {FORMAT!r}")
    try:
        manifest = Manifest.model_validate(document)
    except ValidationError as exc:
        error = exc.errors()[0]
        where = ".".join(str(part) for part in error["loc"])
        raise BackupError(f"invalid backup manifest: {where}: {error['msg']}") from None
    names = [t.name for t in manifest.tables]
    blobs = [(b.sha256, b.suffix) for b in manifest.blobs]
    if len(set(names)) != len(names) or len(set(blobs)) != len(blobs):
        raise BackupError("invalid backup manifest: a table or blob is listed twice")
    return manifest


def schema_tables(connection: Connection) -> list[Table]:
    """The database's own tables in foreign-key order (parents first), without Alembic's.

    The tables are reflected, so a database at any revision is read as it is; columns that
    db/models.py knows get the model's type (UTC timestamps, JSON, booleans) on every dialect.
    """
    reflected = MetaData()
    reflected.reflect(connection)
    tables = [t for t in reflected.sorted_tables if t.name != VERSION_TABLE]
    for table in tables:
        model = Base.metadata.tables.get(table.name)
        for column in table.columns:
            if model is not None and column.name in model.columns:
                column.type = model.columns[column.name].type
    return tables


def blob_columns(table: Table) -> list[tuple[int, str]]:
    """(column index, blob suffix) of the columns of `table` that name a blob in the store.

    Raises BackupError for a sha256 column in neither BLOB_COLUMNS nor DIGEST_COLUMNS, so a
    new reference to the store cannot be left out of backups unnoticed.
    """
    found = []
    for index, column in enumerate(table.columns):
        suffix = BLOB_COLUMNS.get(table.name, {}).get(column.name)
        if suffix is not None:
            found.append((index, suffix))
        elif column.name.endswith("sha256") and (table.name, column.name) not in DIGEST_COLUMNS:
            raise BackupError(
                f"column {table.name}.{column.name} is not known to name a blob or not; "
                "add it to BLOB_COLUMNS or DIGEST_COLUMNS in backend/ops/snapshot.py"
            )
    return found


def read_revision(connection: Connection) -> str | None:
    """The Alembic revision of the database (None when it was never migrated)."""
    if VERSION_TABLE not in inspect(connection).get_table_names():
        return None
    revisions = connection.execute(text(f"SELECT version_num FROM {VERSION_TABLE}")).scalars()
    found = list(revisions)
    if len(found) != 1:
        raise BackupError(f"database has {len(found)} schema revisions; expected exactly one")
    return str(found[0])


def encode_row(values: tuple[Any, ...]) -> str:
    """One row as a JSON array (timestamps as ISO-8601 strings)."""
    return json.dumps(list(values), default=_encode_value, ensure_ascii=False)


def _encode_value(value: object) -> str:
    if isinstance(value, datetime):
        return value.isoformat()
    raise BackupError(f"cannot back up a value of type {type(value).__name__}: {value!r:.60}")


def decode_row(columns: list[Column[Any]], values: list[Any]) -> dict[str, Any]:
    """A row read back from JSON for `columns`, timestamps parsed again."""
    return {
        column.name: _decode_value(column, value)
        for column, value in zip(columns, values, strict=True)
    }


def _decode_value(column: Column[Any], value: Any) -> Any:
    if isinstance(value, str) and _is_timestamp(column):
        return datetime.fromisoformat(value)
    return value


def _is_timestamp(column: Column[Any]) -> bool:
    column_type = column.type
    if isinstance(column_type, TypeDecorator):
        column_type = column_type.impl_instance
    return isinstance(column_type, DateTime)


def fsync_folder(folder: Path) -> None:
    """Make the renames into `folder` durable."""
    handle = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(handle)
    finally:
        os.close(handle)
