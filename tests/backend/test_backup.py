"""`wheelscan backup` → `wheelscan restore` gives back every row and every blob, byte for byte,
on SQLite, on PostgreSQL and across the two; a backup taken while passes are written holds
complete passes only.

The source data directory holds real work: a simulated pass (one axle) uploaded and measured
by the worker's task function with both methods (artefacts and pre-rendered layers in the
store), a small pass measured the same way, and a token.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tarfile
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from alembic.script import ScriptDirectory
from fastapi.testclient import TestClient
from sqlalchemy import select, text

from backend.api.app import create_app
from backend.config import Settings
from backend.ops.backup import create_backup, database_snapshot, dump_tables
from backend.ops.demo import zip_folder
from backend.ops.restore import restore_backup
from backend.ops.snapshot import blob_columns, read_revision
from backend.services.retention import remove_expired_frames
from backend.storage.store import BlobStore
from db.engine import alembic_config, make_engine, make_session_factory, upgrade_database
from db.models import Base, Frame, Site
from db.types import utc_now
from tests.backend.backup_helpers import (
    add_token,
    database_rows,
    ingest,
    measure,
    member_bytes,
    small_pass,
    store_files,
)
from tests.databases import BACKENDS, throwaway_database


@dataclass(frozen=True)
class Source:
    settings: Settings
    viewer_token: str


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory, simulated_pass: Callable) -> Source:
    """A SQLite data directory with measured passes (about 10 s to build)."""
    root = tmp_path_factory.mktemp("backup-source")
    simulated_pass(root / "pass", 1)
    (root / "pass" / "truth.json").unlink()
    settings = Settings(data_dir=root / "data")
    measure(settings, ingest(settings, zip_folder(root / "pass", root / "pass.zip")))
    measure(settings, ingest(settings, small_pass(root, 1)))
    return Source(settings, add_token(settings))


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "backend.cli", *args], capture_output=True, text=True, check=False
    )


def read_manifest(archive: Path) -> dict:
    with tarfile.open(archive) as tar:
        assert tar.getnames()[0] == "manifest.json"
        return json.loads(member_bytes(tar, "manifest.json"))


def test_a_restore_into_an_empty_data_directory_gives_back_every_row_and_blob(source, tmp_path):
    out = tmp_path / "wheelscan.tar"
    backup = run_cli("backup", str(out), "--data", str(source.settings.data_dir))
    assert backup.returncode == 0, backup.stderr
    assert backup.stdout.startswith(f"wheelscan backup: wrote {out} (")
    restored = Settings(data_dir=tmp_path / "restored")
    restore = run_cli("restore", str(out), "--data", str(restored.data_dir))
    assert restore.returncode == 0, restore.stderr

    rows = database_rows(source.settings.resolved_database_url)
    assert database_rows(restored.resolved_database_url) == rows
    assert store_files(restored.frames_dir) == store_files(source.settings.frames_dir)
    states = set(column(rows, "pass_wheel", "state"))
    assert len(rows["train_pass"]) == 2 and {"measured", "not_measured"} <= states
    assert len(rows["measurement"]) == 8 and len(rows["frame"]) == 8
    assert len(rows["measurement_frame"]) > 0 and len(rows["api_token"]) == 1
    with TestClient(create_app(restored.model_copy(update={"workers": 1}))) as client:
        viewer = {"Authorization": f"Bearer {source.viewer_token}"}
        passes = client.get("/api/passes", headers=viewer).json()["items"]
        wheels = client.get(f"/api/passes/{passes[-1]['id']}/wheels", headers=viewer).json()
        base = f"/api/passes/{passes[-1]['id']}/wheels/{wheels[0]['wheel_id']}"
        for layer in ("frames/inner.png", "mask/outer.png", "sigma/inner.png"):
            response = client.get(f"{base}/{layer}", headers=viewer)
            assert response.status_code == 200, (layer, response.text)


def column(rows: dict[str, list[tuple]], table: str, name: str) -> list:
    index = Base.metadata.tables[table].columns.keys().index(name)
    return [row[index] for row in rows[table]]


def test_the_manifest_names_format_revision_dialect_counts_and_every_blob(source, tmp_path):
    summary = create_backup(source.settings, tmp_path / "wheelscan.tar.gz")
    manifest = read_manifest(summary.path)
    head = ScriptDirectory.from_config(alembic_config(make_engine("sqlite://"))).get_current_head()
    assert (manifest["format"], manifest["revision"], manifest["dialect"]) == (
        "wheelscan-backup/1",
        head,
        "sqlite",
    )
    rows = database_rows(source.settings.resolved_database_url)
    assert {t["name"]: t["rows"] for t in manifest["tables"]} == {
        n: len(r) for n, r in rows.items()
    }
    files = store_files(source.settings.frames_dir)
    assert {f"{b['sha256'][:2]}/{b['sha256']}{b['suffix']}" for b in manifest["blobs"]} == set(
        files
    )
    assert [p.name for p in tmp_path.iterdir()] == ["wheelscan.tar.gz"]  # no temporary left


@pytest.mark.postgres
def test_a_sqlite_backup_restores_into_postgresql_and_a_postgresql_one_again(source, tmp_path):
    sqlite_backup = create_backup(source.settings, tmp_path / "sqlite.tar.gz").path
    rows = database_rows(source.settings.resolved_database_url)
    with (
        throwaway_database("postgresql", tmp_path) as first_url,
        throwaway_database("postgresql", tmp_path) as second_url,
    ):
        first = Settings(data_dir=tmp_path / "first", database_url=first_url)
        restore_backup(first, sqlite_backup)
        assert database_rows(first_url) == rows
        postgres_backup = create_backup(first, tmp_path / "postgresql.tar")
        assert postgres_backup.manifest.dialect == "postgresql"

        second = Settings(data_dir=tmp_path / "second", database_url=second_url)
        restore_backup(second, postgres_backup.path)
        assert database_rows(second_url) == rows
        assert store_files(second.frames_dir) == store_files(source.settings.frames_dir)
        engine = make_engine(second_url)
        with make_session_factory(engine)() as session:
            site = Site(name="added after the restore")
            session.add(site)
            session.commit()
            assert site.id == max(row[0] for row in rows["site"]) + 1
        engine.dispose()


@pytest.mark.parametrize("backend", BACKENDS)
def test_rows_written_after_the_snapshot_began_are_not_in_the_backup(backend, tmp_path):
    with throwaway_database(backend, tmp_path) as url:
        settings = Settings(data_dir=tmp_path / "data", database_url=url)
        ingest(settings, small_pass(tmp_path, 1))
        engine = make_engine(url)
        with database_snapshot(engine) as (connection, _revision):
            ingest(settings, small_pass(tmp_path, 2))  # committed by another connection
            tables, blobs = dump_tables(connection, tmp_path / "spool")
        with engine.connect() as connection:
            first_frames = connection.scalars(select(Frame.sha256).where(Frame.pass_id == 1))
            expected_blobs = {(sha256, ".png") for sha256 in first_frames}
        engine.dispose()
    counts = {table.name: table.rows for table in tables}
    assert (counts["train_pass"], counts["frame"], counts["job"]) == (1, 4, 1)
    assert blobs == expected_blobs


def test_a_backup_taken_while_passes_are_written_restores_whole_passes(tmp_path):
    settings = Settings(data_dir=tmp_path / "data")
    ingest(settings, small_pass(tmp_path, 0))
    archives = [small_pass(tmp_path, number) for number in range(1, 25)]
    started, stop = threading.Event(), threading.Event()

    def write_passes() -> None:
        for archive in archives:
            ingest(settings, archive)
            started.set()
            if stop.is_set():
                return

    writer = threading.Thread(target=write_passes)
    writer.start()
    started.wait()
    try:
        summary = create_backup(settings, tmp_path / "during.tar")
    finally:
        stop.set()
        writer.join()
    restored = Settings(data_dir=tmp_path / "restored")
    restore_backup(restored, summary.path)
    rows = database_rows(restored.resolved_database_url)
    passes = len(rows["train_pass"])
    assert 2 <= passes <= 25
    assert (len(rows["frame"]), len(rows["pass_wheel"]), len(rows["job"])) == (
        4 * passes,
        2 * passes,
        passes,
    )
    frames = store_files(restored.frames_dir)
    assert {f"{sha[:2]}/{sha}.png" for sha in column(rows, "frame", "sha256")} == set(frames)


@pytest.mark.parametrize("target_revision", [None, "head"])
def test_a_backup_of_an_older_schema_restores_at_its_revision(target_revision, tmp_path):
    """Into a database never migrated, or one migrated to the newest schema but empty."""
    source = Settings(data_dir=tmp_path / "old")
    engine = make_engine(source.resolved_database_url)
    upgrade_database(engine, "0003")
    with engine.begin() as connection:
        # The 0003 schema's columns only: the models' defaults name columns added later.
        connection.execute(
            text("INSERT INTO site (name, created_at) VALUES (:name, :created_at)"),
            {"name": "old", "created_at": utc_now()},
        )
    engine.dispose()
    summary = create_backup(source, tmp_path / "old.tar")
    assert summary.manifest.revision == "0003"
    restored = Settings(data_dir=tmp_path / "restored")
    if target_revision is not None:
        engine = make_engine(restored.resolved_database_url)
        upgrade_database(engine, target_revision)
        engine.dispose()
    restore_backup(restored, summary.path)
    for settings in (source, restored):
        engine = make_engine(settings.resolved_database_url)
        with engine.connect() as connection:
            assert read_revision(connection) == "0003"
        upgrade_database(engine)
        engine.dispose()
    restored_rows = database_rows(restored.resolved_database_url)
    assert restored_rows == database_rows(source.resolved_database_url)
    assert column(restored_rows, "site", "name") == ["old"]


def test_every_sha256_column_of_the_models_is_known_to_name_a_blob_or_not():
    for table in Base.metadata.sorted_tables:
        blob_columns(table)  # raises for a sha256 column nobody classified
    frame_columns = blob_columns(Base.metadata.tables["measurement_frame"])
    assert sorted(suffix for _index, suffix in frame_columns) == [".npz", ".png", ".png"]


def test_a_pass_whose_frames_retention_removed_is_backed_up_without_them(tmp_path):
    settings = Settings(data_dir=tmp_path / "data")
    measure(settings, ingest(settings, small_pass(tmp_path, 1)))
    ingest(settings, small_pass(tmp_path, 2))  # its wheels still queued: it keeps its frames
    engine = make_engine(settings.resolved_database_url)
    with make_session_factory(engine)() as session:
        store = BlobStore(settings.frames_dir)
        removed = remove_expired_frames(session, store, 1.0)
    engine.dispose()
    assert [removal.pass_id for removal in removed] == [1]

    restored = Settings(data_dir=tmp_path / "restored")
    restore_backup(restored, create_backup(settings, tmp_path / "b.tar").path)
    rows = database_rows(restored.resolved_database_url)
    assert rows == database_rows(settings.resolved_database_url)
    assert store_files(restored.frames_dir) == store_files(settings.frames_dir)
    assert len(rows["frame"]) == 8  # the rows of the removed frames stay
