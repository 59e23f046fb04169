"""Every bad input to `wheelscan backup` and `wheelscan restore` ends in one line on stderr and
exit status 2, and leaves the target as empty as it was: nothing half-restored."""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import subprocess
import sys
import tarfile
from collections.abc import Callable
from pathlib import Path

import pytest

from backend.cli import main
from backend.config import Settings
from backend.ops.backup import create_backup
from tests.backend.backup_helpers import (
    database_rows,
    ingest,
    measure,
    member_bytes,
    rewrite_backup,
    small_pass,
    store_files,
    table_names,
)
from tests.databases import BACKENDS, throwaway_database


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Settings:
    root = tmp_path_factory.mktemp("backup-errors")
    settings = Settings(data_dir=root / "data")
    measure(settings, ingest(settings, small_pass(root, 1)))
    return settings


@pytest.fixture(scope="module")
def backup(source: Settings, tmp_path_factory: pytest.TempPathFactory) -> bytes:
    return create_backup(source, tmp_path_factory.mktemp("good") / "good.tar").path.read_bytes()


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    """The CLI's exit status and its stderr."""
    status = main(list(argv))
    return status, capsys.readouterr().err


def files_under(folder: Path) -> list[Path]:
    return [path for path in folder.rglob("*") if path.is_file()] if folder.exists() else []


def with_manifest(change: Callable[[dict], None]) -> Callable[[bytes], bytes]:
    def spoil(data: bytes) -> bytes:
        def edit(name: str, content: bytes) -> bytes:
            if name != "manifest.json":
                return content
            manifest = json.loads(content)
            change(manifest)
            return json.dumps(manifest).encode()

        return rewrite_backup(data, edit)

    return spoil


def with_members(change: Callable[[str, bytes], bytes | None]) -> Callable[[bytes], bytes]:
    return lambda data: rewrite_backup(data, change)


def flip_last_byte(prefix: str) -> Callable[[str, bytes], bytes]:
    def change(name: str, content: bytes) -> bytes:
        return content[:-1] + bytes([content[-1] ^ 1]) if name.startswith(prefix) else content

    return change


def other_tar(_data: bytes) -> bytes:
    out = io.BytesIO()
    with tarfile.open(fileobj=out, mode="w") as tar:
        info = tarfile.TarInfo("notes.txt")
        info.size = 5
        tar.addfile(info, io.BytesIO(b"notes"))
    return out.getvalue()


def a_blob_as_symlink(data: bytes) -> bytes:
    """The backup with its first blob replaced by a symbolic link to /etc/passwd."""
    out = io.BytesIO()
    with (
        tarfile.open(fileobj=io.BytesIO(data)) as source,
        tarfile.open(fileobj=out, mode="w", format=tarfile.PAX_FORMAT) as target,
    ):
        blobs = [m.name for m in source.getmembers() if m.name.startswith("blobs/")]
        for member in source.getmembers():
            if member.name == blobs[0]:
                link = tarfile.TarInfo(member.name)
                link.type, link.linkname = tarfile.SYMTYPE, "/etc/passwd"
                target.addfile(link)
            else:
                target.addfile(member, source.extractfile(member))
    return out.getvalue()


BAD_ARCHIVES = {
    "not an archive": (lambda _d: b"PK\x03\x04 a zip, not a backup" * 40, "not a readable tar"),
    "another tar": (other_tar, "its first member is not manifest.json"),
    "truncated": (lambda d: d[: len(d) // 2], "truncated"),
    "truncated gzip": (lambda d: gzip.compress(d)[:-300], "truncated"),
    "a blob dropped": (
        with_members(lambda name, c: None if name.startswith("blobs/") else c),
        "is truncated: ",
    ),
    "symlink member": (a_blob_as_symlink, "is not a regular file"),
    "tampered blob": (with_members(flip_last_byte("blobs/")), "does not match its sha256"),
    "tampered rows": (with_members(flip_last_byte("tables/frame")), "does not match its sha256"),
    "extra member": (
        lambda d: rewrite_backup(d, lambda _n, c: c, {"blobs/../../escape": b"x"}),
        "'blobs/../../escape' of the backup is not in its manifest",
    ),
    "manifest not JSON": (
        with_members(lambda name, c: b"{" if name == "manifest.json" else c),
        "manifest.json is not JSON",
    ),
    "format version": (
        with_manifest(lambda m: m.update(format="wheelscan-backup/2")),
        "unsupported backup format 'wheelscan-backup/2'; this wheelscan reads",
    ),
    "bad blob name": (
        with_manifest(lambda m: m["blobs"][0].update(sha256="../x")),
        "invalid backup manifest: blobs.0.sha256",
    ),
    "unknown revision": (
        with_manifest(lambda m: m.update(revision="9999")),
        "revision '9999' is unknown to this wheelscan",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_ARCHIVES))
def test_a_bad_archive_is_refused_in_one_line_and_nothing_is_written(
    case, backup, tmp_path, capsys
):
    spoil, expected = BAD_ARCHIVES[case]
    archive = tmp_path / "in.tar"
    archive.write_bytes(spoil(backup))
    target = tmp_path / "target"
    status, stderr = run(capsys, "restore", str(archive), "--data", str(target))
    assert status == 2
    assert stderr.startswith("wheelscan restore: error: ") and stderr.count("\n") == 1
    assert expected in stderr
    assert files_under(target) == []


def test_the_real_command_line_shows_no_traceback(backup, tmp_path):
    archive = tmp_path / "in.tar"
    archive.write_bytes(backup[:1000])
    result = subprocess.run(
        [sys.executable, "-m", "backend.cli", "restore", str(archive), "--data", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1 and "truncated" in result.stderr


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_target_that_is_not_empty_is_refused(backend, backup, tmp_path, capsys):
    archive = tmp_path / "in.tar"
    archive.write_bytes(backup)
    with throwaway_database(backend, tmp_path) as url:
        target = ("--data", str(tmp_path / "target"), "--database-url", url)
        assert run(capsys, "restore", str(archive), *target)[0] == 0
        before = database_rows(url)
        status, stderr = run(capsys, "restore", str(archive), *target)
        assert status == 2 and "the frame store" in stderr and "is not empty" in stderr
        for blob in files_under(tmp_path / "target" / "store"):
            blob.unlink()
        status, stderr = run(capsys, "restore", str(archive), *target)
        assert status == 2
        assert "the database is not empty (table " in stderr
        assert "restore only into an empty database" in stderr
        assert database_rows(url) == before


def duplicate_a_frame_row(data: bytes) -> bytes:
    """A backup consistent in itself whose frame table repeats a row (same id)."""
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        lines = member_bytes(tar, "tables/frame.jsonl").splitlines(keepends=True)
    rows = b"".join([*lines, lines[-1]])

    def change(name: str, content: bytes) -> bytes:
        if name == "tables/frame.jsonl":
            return rows
        if name != "manifest.json":
            return content
        manifest = json.loads(content)
        entry = next(t for t in manifest["tables"] if t["name"] == "frame")
        entry.update(
            rows=entry["rows"] + 1, bytes=len(rows), sha256=hashlib.sha256(rows).hexdigest()
        )
        return json.dumps(manifest).encode()

    return rewrite_backup(data, change)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_restore_failing_in_the_database_leaves_nothing_behind(backend, backup, tmp_path, capsys):
    archive = tmp_path / "in.tar"
    archive.write_bytes(duplicate_a_frame_row(backup))
    with throwaway_database(backend, tmp_path / "db") as url:
        target = tmp_path / "target"
        status, stderr = run(capsys, "restore", str(archive), "--data", str(target),
                             "--database-url", url)  # fmt: skip
        assert status == 2 and stderr.startswith("wheelscan restore: error: database: ")
        assert stderr.count("\n") == 1
        assert files_under(target) == []
        if backend == "postgresql":
            assert set(table_names(url)) <= {"alembic_version"}
        else:
            assert not Path(url.removeprefix("sqlite:///")).exists()


def test_backup_refuses_an_existing_out_a_missing_folder_and_a_missing_database(
    source, tmp_path, capsys
):
    taken = tmp_path / "taken.tar"
    taken.write_bytes(b"an earlier backup")
    data = ("--data", str(source.data_dir))
    status, stderr = run(capsys, "backup", str(taken), *data)
    assert status == 2 and "taken.tar exists; a backup never overwrites a file" in stderr
    assert taken.read_bytes() == b"an earlier backup"
    status, stderr = run(capsys, "backup", str(tmp_path / "no" / "b.tar"), *data)
    assert status == 2 and "does not exist" in stderr
    status, stderr = run(capsys, "backup", str(tmp_path / "b.tar"), "--data", str(tmp_path / "x"))
    assert status == 2 and "no database at" in stderr and not (tmp_path / "x").exists()


def test_backup_refuses_a_database_it_cannot_reach_in_one_line(tmp_path, capsys):
    url = "postgresql+psycopg://postgres@127.0.0.1:9/none"
    status, stderr = run(capsys, "backup", str(tmp_path / "b.tar"), "--database-url", url)
    assert status == 2 and stderr.startswith("wheelscan backup: error: database: ")
    assert stderr.count("\n") == 1 and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("damage", ["missing", "corrupt"])
def test_backup_refuses_a_store_that_lacks_or_garbles_a_blob(damage, backup, tmp_path, capsys):
    archive = tmp_path / "good.tar"
    archive.write_bytes(backup)
    copy = Settings(data_dir=tmp_path / "data")
    assert main(["restore", str(archive), "--data", str(copy.data_dir)]) == 0
    blob = sorted(files_under(copy.frames_dir))[0]
    if damage == "missing":
        blob.unlink()
    else:
        blob.write_bytes(blob.read_bytes()[:-1] + b"\0")
    capsys.readouterr()
    out = tmp_path / "out" / "b.tar"
    out.parent.mkdir()
    status, stderr = run(capsys, "backup", str(out), "--data", str(copy.data_dir))
    expected = "lacks 1 blob(s)" if damage == "missing" else "does not match its sha256"
    assert status == 2 and expected in stderr and "no backup written" in stderr
    assert list(out.parent.iterdir()) == []
    assert store_files(copy.frames_dir)  # the store itself is left as it was
