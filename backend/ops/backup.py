"""`wheelscan backup`: the database and the frame store as one consistent archive.

The rows are read in one read-only transaction that sees a single instant of the database
(REPEATABLE READ on PostgreSQL, a read transaction on SQLite's write-ahead log), so the
server may go on writing meanwhile. The blobs copied are exactly those the snapshot's rows
name: blobs are immutable and content-addressed, so one written later changes none of them,
and each is checked against its sha256 as it is copied. The archive is written under a
temporary name beside OUT, fsynced, and renamed to OUT only when complete.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tarfile
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from sqlalchemy import Connection, Engine, Row, Table, select
from sqlalchemy.engine import make_url
from tqdm import tqdm

from backend.config import Settings
from backend.ops.snapshot import (
    FORMAT,
    MANIFEST_MEMBER,
    BackupError,
    BlobEntry,
    Manifest,
    TableEntry,
    blob_columns,
    blob_member,
    encode_row,
    fsync_folder,
    read_revision,
    schema_tables,
    table_member,
)
from backend.storage.store import BlobStore
from db.engine import make_engine
from db.types import utc_now
from pipeline.version import PIPELINE_VERSION

ROWS_PER_FETCH = 2000
GZIP_LEVEL = 6
"""Frames and artefacts are compressed already; level 6 mainly shrinks the row files."""


@dataclass(frozen=True, slots=True)
class BackupSummary:
    """What a backup wrote."""

    path: Path
    manifest: Manifest
    archive_bytes: int
    seconds: float


def create_backup(settings: Settings, out: Path) -> BackupSummary:
    """Write the database and the blobs its rows name to the archive `out` (a new file).

    `out` ending in .tar.gz or .tgz is gzip-compressed, any other name is a plain tar.
    Raises BackupError (nothing written) when `out` exists, the database was never
    migrated, or a blob the database names is missing or corrupt in the store.
    """
    started = time.monotonic()
    if out.exists():
        raise BackupError(f"{out} exists; a backup never overwrites a file")
    if not out.parent.is_dir():
        raise BackupError(f"folder {out.parent} does not exist")
    url = make_url(settings.resolved_database_url)
    if url.get_backend_name() == "sqlite" and not Path(url.database or "").is_file():
        raise BackupError(f"no database at {url.database}")
    engine = make_engine(settings.resolved_database_url)
    store = BlobStore(settings.frames_dir)
    try:
        with tempfile.TemporaryDirectory(dir=out.parent, prefix=f".{out.name}.") as spool:
            with database_snapshot(engine) as (connection, revision):
                tables, references = dump_tables(connection, Path(spool))
            manifest = Manifest(
                format=FORMAT,
                created_at=utc_now(),
                pipeline_version=PIPELINE_VERSION,
                revision=revision,
                dialect=engine.dialect.name,
                tables=tables,
                blobs=list_blobs(store, references),
            )
            size = write_archive(out, manifest, Path(spool), store)
    finally:
        engine.dispose()
    return BackupSummary(out, manifest, size, time.monotonic() - started)


@contextmanager
def database_snapshot(engine: Engine) -> Iterator[tuple[Connection, str]]:
    """A read-only transaction that sees the database at one instant, and its revision.

    The instant is the transaction's first read (the revision), before this yields.
    """
    with engine.connect() as connection:
        if engine.dialect.name == "postgresql":
            connection.execution_options(
                isolation_level="REPEATABLE READ", postgresql_readonly=True
            )
        else:
            # pysqlite opens no transaction for reads; an explicit one keeps this reader on
            # one snapshot of the write-ahead log from its first read until it ends.
            connection.exec_driver_sql("BEGIN")
        try:
            revision = read_revision(connection)
            if revision is None:
                raise BackupError("the database has no wheelscan schema; nothing to back up")
            yield connection, revision
        finally:
            connection.rollback()


def dump_tables(
    connection: Connection, spool: Path
) -> tuple[list[TableEntry], set[tuple[str, str]]]:
    """Write every table's rows as JSON lines under `spool`.

    Returns the tables' entries and the blobs (sha256, suffix) that the rows name.
    """
    references = BlobReferences()
    entries = [
        _dump_table(connection, table, spool, references) for table in schema_tables(connection)
    ]
    return entries, references.blobs


def _dump_table(
    connection: Connection, table: Table, spool: Path, references: BlobReferences
) -> TableEntry:
    path = spool / table_member(table.name)
    path.parent.mkdir(parents=True, exist_ok=True)
    query = select(table).order_by(*table.primary_key.columns)
    digest, rows = hashlib.sha256(), 0
    with path.open("wb") as stream:
        header = json.dumps({"columns": [column.name for column in table.columns]})
        lines = [f"{header}\n".encode()]
        for row in connection.execute(query.execution_options(yield_per=ROWS_PER_FETCH)):
            references.note(table, row)
            lines.append(f"{encode_row(tuple(row))}\n".encode())
            rows += 1
            if len(lines) >= ROWS_PER_FETCH:
                _write_hashed(stream, digest, lines)
        _write_hashed(stream, digest, lines)
    return TableEntry(
        name=table.name, rows=rows, bytes=path.stat().st_size, sha256=digest.hexdigest()
    )


class BlobReferences:
    """The blobs that rows name, taken in table by table in foreign-key order.

    Frame retention (backend/services/retention.py) deletes the raw frame blobs of a pass and sets
    its `frames_removed_at`, keeping the frame rows: those rows name no blob any more.
    """

    def __init__(self) -> None:
        self.blobs: set[tuple[str, str]] = set()
        self._columns: dict[str, list[tuple[int, str]]] = {}
        self._frames_removed: set[int] = set()

    def note(self, table: Table, row: Row[Any]) -> None:
        """Take in the blobs that one row of `table` names."""
        values = row._mapping
        if table.name == "train_pass" and values.get("frames_removed_at") is not None:
            self._frames_removed.add(values["id"])
        if table.name == "frame" and values["pass_id"] in self._frames_removed:
            return
        if table.name not in self._columns:
            self._columns[table.name] = blob_columns(table)
        self.blobs.update((row[i], suffix) for i, suffix in self._columns[table.name] if row[i])


def _write_hashed(stream: BinaryIO, digest: hashlib._Hash, lines: list[bytes]) -> None:
    data = b"".join(lines)
    stream.write(data)
    digest.update(data)
    lines.clear()


def list_blobs(store: BlobStore, references: set[tuple[str, str]]) -> list[BlobEntry]:
    """The manifest entries of the referenced blobs; BackupError when any is missing."""
    entries, missing = [], []
    for sha256, suffix in sorted(references):
        try:
            size = store.path_for(sha256, suffix).stat().st_size
        except FileNotFoundError:
            missing.append(f"{sha256}{suffix}")
            continue
        entries.append(BlobEntry(sha256=sha256, suffix=suffix, bytes=size))  # type: ignore[arg-type]
    if missing:
        raise BackupError(
            f"the frame store {store.root} lacks {len(missing)} blob(s) the database names "
            f"(first: {missing[0]}; lost, or removed by frame retention meanwhile: then "
            "back up again); no backup written"
        )
    return entries


def write_archive(out: Path, manifest: Manifest, spool: Path, store: BlobStore) -> int:
    """Write the archive under a temporary name beside `out`, fsync, rename; its size."""
    compressed = out.name.endswith((".tar.gz", ".tgz"))
    handle, temporary = tempfile.mkstemp(dir=out.parent, prefix=f".{out.name}.", suffix=".partial")
    mtime = manifest.created_at.timestamp()
    try:
        with os.fdopen(handle, "wb") as raw:
            with _open_for_writing(raw, compressed) as tar:
                manifest_json = manifest.model_dump_json(indent=1).encode()
                tar.addfile(
                    _member(MANIFEST_MEMBER, len(manifest_json), mtime), io.BytesIO(manifest_json)
                )
                for table in manifest.tables:
                    with (spool / table_member(table.name)).open("rb") as rows:
                        tar.addfile(_member(table_member(table.name), table.bytes, mtime), rows)
                _add_blobs(tar, store, manifest.blobs, mtime)
            raw.flush()
            os.fsync(raw.fileno())
            size = raw.tell()
        if out.exists():
            raise BackupError(f"{out} appeared while the backup was written; left untouched")
        os.replace(temporary, out)
        fsync_folder(out.parent)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return size


def _open_for_writing(raw: BinaryIO, compressed: bool) -> tarfile.TarFile:
    if compressed:
        return tarfile.open(
            fileobj=raw, mode="w:gz", format=tarfile.PAX_FORMAT, compresslevel=GZIP_LEVEL
        )
    return tarfile.open(fileobj=raw, mode="w", format=tarfile.PAX_FORMAT)


def _add_blobs(
    tar: tarfile.TarFile, store: BlobStore, blobs: list[BlobEntry], mtime: float
) -> None:
    total = sum(blob.bytes for blob in blobs)
    with tqdm(total=total, unit="B", unit_scale=True, desc="backup", disable=None) as bar:
        for blob in blobs:
            try:
                source = store.path_for(blob.sha256, blob.suffix).open("rb")
            except FileNotFoundError:
                raise BackupError(
                    f"blob {blob.sha256}{blob.suffix} left the frame store while the backup "
                    "ran (frame retention?); back up again; no backup written"
                ) from None
            with source:
                reader = _HashingReader(source)
                tar.addfile(
                    _member(blob_member(blob.sha256, blob.suffix), blob.bytes, mtime), reader
                )
            if reader.hexdigest() != blob.sha256:
                raise BackupError(
                    f"blob {blob.sha256}{blob.suffix} in the frame store does not match its "
                    "sha256 (corrupt on disk); no backup written"
                )
            bar.update(blob.bytes)


class _HashingReader:
    """A binary stream that hashes (sha256) what is read through it."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self._digest = hashlib.sha256()

    def read(self, size: int = -1) -> bytes:
        data = self._stream.read(size)
        self._digest.update(data)
        return data

    def hexdigest(self) -> str:
        """The sha256 of everything read so far."""
        return self._digest.hexdigest()


def _member(name: str, size: int, mtime: float) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.size, info.mtime, info.mode = size, mtime, 0o644
    return info
