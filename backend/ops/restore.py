"""`wheelscan restore`: a backup into an empty frame store and an empty database.

Nothing goes into the store or the database before the whole archive has been read and
every member matched its size and sha256 in the manifest (members are unpacked into a
staging folder inside the data directory meanwhile). Then the database is migrated to the
backup's revision, a transaction begins, the blobs are renamed into the store (nothing
names them before the commit), every row is inserted, PostgreSQL's id sequences are moved
past the restored ids, and the transaction is committed. A failure rolls back, removes the
blobs renamed so far and takes the schema back to empty: a failed restore leaves the target
as empty as it found it.
"""

from __future__ import annotations

import hashlib
import json
import os
import tarfile
import tempfile
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from alembic.script import ScriptDirectory
from alembic.util import CommandError
from sqlalchemy import Connection, Engine, Integer, func, inspect, select, table, text
from sqlalchemy.engine import make_url
from tqdm import tqdm

from backend.config import Settings
from backend.ops.snapshot import (
    MANIFEST_MEMBER,
    MAX_MANIFEST_BYTES,
    VERSION_TABLE,
    BackupError,
    Manifest,
    blob_member,
    decode_row,
    fsync_folder,
    parse_manifest,
    read_revision,
    schema_tables,
    table_member,
)
from backend.storage.store import BlobStore
from db.engine import alembic_config, downgrade_database, make_engine, upgrade_database

CHUNK_BYTES = 1024 * 1024
ROWS_PER_INSERT = 1000


@dataclass(frozen=True, slots=True)
class RestoreSummary:
    """What a restore put back."""

    manifest: Manifest
    seconds: float


def restore_backup(settings: Settings, archive: Path) -> RestoreSummary:
    """Restore the backup `archive` into the settings' (empty) frame store and database.

    Raises BackupError, with the target left as it was, when the target is not empty or
    the archive is not a complete, untampered wheelscan backup this version can read.
    """
    started = time.monotonic()
    if not archive.is_file():
        raise BackupError(f"{archive} is not a file")
    store = BlobStore(settings.frames_dir)
    check_store_empty(store)
    url = make_url(settings.resolved_database_url)
    sqlite_file = (
        Path(url.database) if url.get_backend_name() == "sqlite" and url.database else None
    )
    created_file = sqlite_file is not None and not sqlite_file.exists()
    engine = make_engine(settings.resolved_database_url)
    try:
        check_database_empty(engine)
        settings.data_dir.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=settings.data_dir, prefix=".restore-") as staging:
            manifest = unpack_verified(archive, Path(staging))
            check_revision_known(engine, manifest.revision)
            load_backup(engine, store, manifest, Path(staging))
    except BaseException:
        engine.dispose()
        if created_file and sqlite_file is not None:
            for suffix in ("", "-wal", "-shm", "-journal"):
                Path(f"{sqlite_file}{suffix}").unlink(missing_ok=True)
        raise
    engine.dispose()
    return RestoreSummary(manifest, time.monotonic() - started)


def check_store_empty(store: BlobStore) -> None:
    """BackupError when the frame store holds any file."""
    if not store.root.exists():
        return
    found = next((path for path in store.root.rglob("*") if path.is_file()), None)
    if found is not None:
        raise BackupError(
            f"the frame store {store.root} is not empty ({found.name}); "
            "restore only into an empty data directory"
        )


def check_database_empty(engine: Engine) -> None:
    """BackupError when any table of the database holds a row (an empty schema is fine)."""
    with engine.connect() as connection:
        for name in sorted(inspect(connection).get_table_names()):
            if name == VERSION_TABLE:
                continue
            rows = connection.execute(select(func.count()).select_from(table(name))).scalar_one()
            if rows:
                raise BackupError(
                    f"the database is not empty (table {name} has {rows} row(s)); "
                    "restore only into an empty database"
                )


def check_revision_known(engine: Engine, revision: str) -> None:
    """BackupError when this wheelscan has no migration called `revision`."""
    scripts = ScriptDirectory.from_config(alembic_config(engine))
    try:
        known = scripts.get_revision(revision) is not None
    except CommandError:
        known = False
    if not known:
        raise BackupError(
            f"the backup's schema revision {revision!r} is unknown to this wheelscan "
            f"(newest known: {scripts.get_current_head()}); restore with a newer wheelscan"
        )


def unpack_verified(archive: Path, staging: Path) -> Manifest:
    """Unpack `archive` into `staging`, checking every member against the manifest."""
    try:
        with (
            archive.open("rb") as raw,
            tarfile.open(fileobj=raw, mode="r|*") as tar,
            tqdm(total=archive.stat().st_size, unit="B", unit_scale=True, desc="verify",
                 disable=None) as bar,
        ):  # fmt: skip
            members = iter(tar)
            manifest = _read_manifest(tar, next(members, None))
            expected = {table_member(t.name): (t.bytes, t.sha256) for t in manifest.tables}
            expected.update(
                {blob_member(b.sha256, b.suffix): (b.bytes, b.sha256) for b in manifest.blobs}
            )
            for member in members:
                _unpack_member(tar, member, expected, staging)
                bar.update(raw.tell() - bar.n)
    except (tarfile.TarError, EOFError, zlib.error) as exc:
        raise BackupError(
            f"{archive} is not a readable tar archive or is truncated ({exc})"
        ) from None
    if expected:
        raise BackupError(
            f"{archive} is truncated: {len(expected)} member(s) of its manifest are missing "
            f"(first: {next(iter(expected))})"
        )
    return manifest


def _read_manifest(tar: tarfile.TarFile, member: tarfile.TarInfo | None) -> Manifest:
    if member is None or member.name != MANIFEST_MEMBER or not member.isreg():
        raise BackupError(f"not a wheelscan backup: its first member is not {MANIFEST_MEMBER}")
    if member.size > MAX_MANIFEST_BYTES:
        raise BackupError(f"not a wheelscan backup: {MANIFEST_MEMBER} is {member.size} bytes")
    return parse_manifest(_member_data(tar, member).read())


def _unpack_member(
    tar: tarfile.TarFile,
    member: tarfile.TarInfo,
    expected: dict[str, tuple[int, str]],
    staging: Path,
) -> None:
    spec = expected.pop(member.name, None)
    if spec is None:
        raise BackupError(f"member {member.name!r} of the backup is not in its manifest")
    if not member.isreg():
        raise BackupError(f"member {member.name} of the backup is not a regular file")
    size, sha256 = spec
    if member.size != size:
        raise BackupError(f"member {member.name} is {member.size} bytes; its manifest says {size}")
    # The path comes from the manifest's checked names (table names, sha256s), never the tar.
    target = staging / member.name
    target.parent.mkdir(parents=True, exist_ok=True)
    source = _member_data(tar, member)
    digest = hashlib.sha256()
    with target.open("wb") as out:
        while chunk := source.read(CHUNK_BYTES):
            digest.update(chunk)
            out.write(chunk)
        out.flush()
        os.fsync(out.fileno())
    if digest.hexdigest() != sha256:
        raise BackupError(
            f"member {member.name} does not match its sha256 in the manifest (tampered or corrupt)"
        )


def _member_data(tar: tarfile.TarFile, member: tarfile.TarInfo) -> IO[bytes]:
    source = tar.extractfile(member)
    if source is None:
        raise BackupError(f"member {member.name} of the backup is not a regular file")
    return source


def load_backup(engine: Engine, store: BlobStore, manifest: Manifest, staging: Path) -> None:
    """Migrate, move the blobs into the store and insert every row: all or nothing."""
    _migrate_empty_database(engine, manifest.revision)
    moved: list[Path] = []
    try:
        with engine.begin() as connection:
            move_blobs(store, manifest, staging, moved)
            insert_rows(connection, manifest, staging)
            if connection.dialect.name == "postgresql":
                reset_sequences(connection)
    except BaseException:
        for path in moved:
            path.unlink(missing_ok=True)
        downgrade_database(engine, "base")
        raise


def _migrate_empty_database(engine: Engine, revision: str) -> None:
    with engine.connect() as connection:
        current = read_revision(connection)
    if current is not None and current != revision:
        downgrade_database(engine, "base")  # it holds no rows: nothing is lost
    upgrade_database(engine, revision)


def insert_rows(connection: Connection, manifest: Manifest, staging: Path) -> None:
    """Insert the backup's rows, parents before children, and check every table's count."""
    tables = {t.name: t for t in schema_tables(connection)}
    unknown = sorted({t.name for t in manifest.tables} - set(tables))
    if unknown:
        raise BackupError(
            f"the backup's table {unknown[0]} is not in the schema at revision {manifest.revision}"
        )
    entries = {t.name: t for t in manifest.tables}
    for name, target in tables.items():
        entry = entries.get(name)
        if entry is None:
            continue
        with (staging / table_member(name)).open("rb") as stream:
            header = json.loads(stream.readline())
            missing = sorted(set(header["columns"]) - set(target.columns.keys()))
            if missing:
                raise BackupError(f"the backup's column {name}.{missing[0]} is not in the schema")
            columns = [target.columns[column] for column in header["columns"]]
            batch = []
            for line in stream:
                batch.append(decode_row(columns, json.loads(line)))
                if len(batch) == ROWS_PER_INSERT:
                    connection.execute(target.insert(), batch)
                    batch = []
            if batch:
                connection.execute(target.insert(), batch)
        rows = connection.execute(select(func.count()).select_from(target)).scalar_one()
        if rows != entry.rows:
            raise BackupError(
                f"table {name}: {rows} row(s) restored, the manifest says {entry.rows}"
            )


def reset_sequences(connection: Connection) -> None:
    """Move every serial id's sequence past the largest restored id (PostgreSQL)."""
    preparer = connection.dialect.identifier_preparer
    for target in schema_tables(connection):
        keys = list(target.primary_key.columns)
        if len(keys) != 1 or not isinstance(keys[0].type, Integer):
            continue
        largest = connection.execute(select(func.max(keys[0]))).scalar_one()
        connection.execute(
            text("SELECT setval(pg_get_serial_sequence(:table, :column), :value, :called)"),
            {
                "table": preparer.format_table(target),
                "column": keys[0].name,
                "value": largest or 1,
                "called": largest is not None,
            },
        )


def move_blobs(store: BlobStore, manifest: Manifest, staging: Path, moved: list[Path]) -> None:
    """Rename the staged blobs into the store (appending each to `moved`), then fsync."""
    store.root.mkdir(parents=True, exist_ok=True)
    folders = set()
    with tqdm(total=len(manifest.blobs), unit="blob", desc="restore", disable=None) as bar:
        for blob in manifest.blobs:
            target = store.path_for(blob.sha256, blob.suffix)
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(staging / blob_member(blob.sha256, blob.suffix), target)
            moved.append(target)
            folders.add(target.parent)
            bar.update()
    for folder in (*sorted(folders), store.root):
        fsync_folder(folder)
