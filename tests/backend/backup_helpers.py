"""Data directories with real passes for the backup tests, and how to compare two of them."""

from __future__ import annotations

import dataclasses
import hashlib
import io
import tarfile
from collections.abc import Callable
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import inspect, select

from backend.config import Settings
from backend.jobs.tasks import measure_pass_wheel
from backend.services.auth import create_token
from backend.services.ingest import store_archive, validate_archive
from backend.storage.store import BlobStore
from db.engine import make_engine, make_session_factory, upgrade_database
from db.models import Base
from pipeline.archive.pass_archive import write_pass_archive
from tests.pipeline.archive_helpers import (
    HEIGHT_PX,
    WIDTH_PX,
    small_calibration,
    small_manifest,
)


def ingest(settings: Settings, archive: Path) -> list[int]:
    """Store a pass archive as an upload does (database migrated first); its pass wheels."""
    engine = make_engine(settings.resolved_database_url)
    try:
        upgrade_database(engine)
        sha256 = hashlib.sha256(archive.read_bytes()).hexdigest()
        with make_session_factory(engine)() as session:
            valid = validate_archive(session, archive, settings)
            store = BlobStore(settings.frames_dir)
            return store_archive(session, store, valid, sha256, None)[2]
    finally:
        engine.dispose()


def measure(settings: Settings, pass_wheel_ids: list[int]) -> None:
    """Measure the wheels in this process, with the task function the workers run."""
    for pass_wheel_id in pass_wheel_ids:
        measure_pass_wheel(pass_wheel_id, settings.resolved_database_url, str(settings.data_dir))


def add_token(settings: Settings) -> str:
    """A viewer token in the settings' database; its plaintext."""
    engine = make_engine(settings.resolved_database_url)
    try:
        with make_session_factory(engine)() as session:
            plaintext = create_token(session, role="viewer", name="backup test")[1]
            session.commit()
    finally:
        engine.dispose()
    return plaintext


def small_pass(folder: Path, number: int) -> Path:
    """A one-axle pass of 40x30 px frames, different (frames, time) for every `number`."""
    manifest = dataclasses.replace(
        small_manifest(), started_at=small_manifest().started_at + timedelta(minutes=number)
    )
    frame = np.zeros((HEIGHT_PX, WIDTH_PX), np.uint8)
    frame[5 + number % 20, :] = 200
    frame[0, 0] = number % 256
    frames = {p: frame for w in manifest.wheels for p in w.frames_inner + w.frames_outer}
    out = folder / f"small-{number}.zip"
    write_pass_archive(out, manifest, frames, calibration=small_calibration())
    return out


def database_rows(database_url: str) -> dict[str, list[tuple[Any, ...]]]:
    """Every row of every table of db/models.py, in primary-key order."""
    engine = make_engine(database_url)
    try:
        with engine.connect() as connection:
            return {
                table.name: [
                    tuple(row)
                    for row in connection.execute(
                        select(table).order_by(*table.primary_key.columns)
                    )
                ]
                for table in Base.metadata.sorted_tables
            }
    finally:
        engine.dispose()


def table_names(database_url: str) -> list[str]:
    engine = make_engine(database_url)
    try:
        with engine.connect() as connection:
            return inspect(connection).get_table_names()
    finally:
        engine.dispose()


def store_files(root: Path) -> dict[str, bytes]:
    """Every file under a frame store, by its path in the store."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def rewrite_backup(
    data: bytes,
    change: Callable[[str, bytes], bytes | None],
    add: dict[str, bytes] | None = None,
) -> bytes:
    """The backup tar with every member's bytes passed through `change` (None drops the
    member) and members added at the end."""
    out = io.BytesIO()
    with (
        tarfile.open(fileobj=io.BytesIO(data)) as source,
        tarfile.open(fileobj=out, mode="w", format=tarfile.PAX_FORMAT) as target,
    ):
        contents = [(m.name, member_bytes(source, m.name)) for m in source.getmembers()]
        for name, content in [*contents, *(add or {}).items()]:
            changed = change(name, content)
            if changed is None:
                continue
            info = tarfile.TarInfo(name)
            info.size = len(changed)
            target.addfile(info, io.BytesIO(changed))
    return out.getvalue()


def member_bytes(tar: tarfile.TarFile, name: str) -> bytes:
    """The content of one regular member of an archive."""
    stream = tar.extractfile(name)
    if stream is None:
        raise ValueError(f"{name} is not a regular member")
    return stream.read()
