"""The data disk nearly full: a small tmpfs mounted as the server's data dir (frame store
and SQLite), filled up to the last MiBs. Uploads are refused with 507 and leave nothing
half-written; reads go on; once space is freed the same upload goes through."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.faults.live import (
    LiveServer,
    check_database,
    check_store,
    upload,
    wait_for_job,
    wheels_of,
)
from tests.scale.topology import synthetic_pass_zip, wait_until

DISK_MIB = 24
"""The data disk: a measured axle pass (3.4 MB of frames, the artefacts, SQLite) and room."""
JOB_TIMEOUT_S = 120.0
MIB = 1024 * 1024


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A tmpfs of DISK_MIB MiB, unmounted afterwards (needs root)."""
    if os.geteuid() != 0:
        pytest.skip("not root: cannot mount a small tmpfs, so the full disk is NOT tested")
    mount_point = tmp_path / "disk"
    mount_point.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={DISK_MIB}m", "tmpfs", str(mount_point)],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"mount -t tmpfs failed ({mounted.stderr.strip()}): full disk NOT tested")
    try:
        yield mount_point
    finally:
        subprocess.run(["umount", "-l", str(mount_point)], timeout=30, check=False)


def fill(disk: Path, leave_bytes: int) -> Path:
    """A file that takes all the disk's free space but `leave_bytes`.

    A server writing to the same disk meanwhile may take the last bytes first: ENOSPC on
    the way means the disk is full, which is the point.
    """
    filler = disk / "filler"
    size_bytes = shutil.disk_usage(disk).free - leave_bytes
    with filler.open("wb") as out:
        try:
            for _ in range(size_bytes // MIB):
                out.write(bytes(MIB))
            out.write(bytes(size_bytes % MIB))
            out.flush()
        except OSError as exc:
            if exc.errno != errno.ENOSPC:
                raise
    return filler


def reads_of(pass_id: int, wheel_id: int) -> list[str]:
    base = f"/api/passes/{pass_id}"
    return [
        "/api/passes",
        base,
        f"{base}/wheels",
        f"{base}/wheels/{wheel_id}",
        f"{base}/wheels/{wheel_id}/frames/inner.png",
        f"{base}/report.csv",
        f"{base}/report.pdf",
    ]


@pytest.fixture(scope="module")
def other_axle_archive(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    """Another simulated axle: frames of its own (the store holds none of them yet), so
    its seed is not the shared simulated pass's (tests/conftest.py, SIMULATED_SEED = 8)."""
    return synthetic_pass_zip(tmp_path_factory.mktemp("other-axle"), 1, 1, seed=9)


@pytest.mark.parametrize(
    ("free_mib", "spool_on_data_disk"),
    [(1, False), (4, False), (1, True)],
    ids=["no room for the upload", "room for the upload not its frames", "no room to spool"],
)
def test_a_nearly_full_disk_refuses_uploads_with_507_and_keeps_serving_reads(
    small_disk: Path,
    make_server: Callable[..., LiveServer],
    axle_archive: bytes,
    other_axle_archive: bytes,
    tmp_path: Path,
    free_mib: int,
    spool_on_data_disk: bool,
) -> None:
    # TMPDIR, where the multipart body is spooled: a container's /tmp, or the full disk too.
    spool = small_disk / "tmp" if spool_on_data_disk else tmp_path / "server-tmp"
    server = make_server(small_disk / "data", tmp_dir=spool, log_dir=tmp_path)
    with server.client() as client:
        first = upload(client, axle_archive).raise_for_status().json()
        wait_for_job(client, first["job_id"], JOB_TIMEOUT_S)
        wheel_id = wheels_of(client, first["pass_id"])[0]["wheel_id"]
        reads = reads_of(first["pass_id"], wheel_id)
        before = {path: client.get(path) for path in reads}
        assert {path: r.status_code for path, r in before.items()} == dict.fromkeys(reads, 200)

        filler = fill(small_disk, free_mib * MIB)
        second = other_axle_archive
        refused = upload(client, second)
        assert refused.status_code == 507, refused.text
        assert refused.json()["code"] == "insufficient_storage"
        assert "disk is full" in refused.json()["detail"]
        for path in reads:
            answer = client.get(path)
            assert answer.status_code == 200, f"{path}: {answer.status_code} {answer.text[:200]}"
            if not path.endswith(".pdf"):  # the PDF carries its generation time
                assert answer.content == before[path].content, path
        problems = check_store(server.data_dir, server.tmp_dir).problems
        problems += check_database(server.settings.resolved_database_url, server.data_dir).problems
        assert not problems, "\n".join(problems)

        filler.unlink()
        accepted = upload(client, second)
        assert accepted.status_code == 202, accepted.text
        wait_for_job(client, accepted.json()["job_id"], JOB_TIMEOUT_S)
        assert [w["state"] for w in wheels_of(client, accepted.json()["pass_id"])] == [
            "measured"
        ] * 2
        assert client.get("/api/passes").json()["total"] == 2


def test_a_disk_filled_during_measurement_holds_the_wheels_until_space_is_freed(
    small_disk: Path,
    make_server: Callable[..., LiveServer],
    other_axle_archive: bytes,
    tmp_path: Path,
) -> None:
    server = make_server(
        small_disk / "data", tmp_dir=tmp_path / "server-tmp", log_dir=tmp_path, workers=1
    )
    with server.client() as client:
        accepted = upload(client, other_axle_archive)
        assert accepted.status_code == 202, accepted.text
        pass_id = accepted.json()["pass_id"]
        wait_until(
            lambda: "running" in {w["state"] for w in wheels_of(client, pass_id)},
            JOB_TIMEOUT_S,
            "a wheel being measured",
        )
        filler = fill(small_disk, 0)
        wait_until(
            lambda: "full; measuring it again" in server.log_tail(20000),
            JOB_TIMEOUT_S,
            "a measurement to meet the full disk",
        )
        wheels = wheels_of(client, pass_id)
        assert {w["state"] for w in wheels} <= {"queued", "running"}, wheels
        filler.unlink()
        job = wait_for_job(client, accepted.json()["job_id"], JOB_TIMEOUT_S)
        assert (job["wheels_done"], job["wheels_total"]) == (2, 2)
        wheels = wheels_of(client, pass_id)
        assert [w["state"] for w in wheels] == ["measured"] * 2, wheels
    problems = check_store(server.data_dir, server.tmp_dir).problems
    problems += check_database(server.settings.resolved_database_url, server.data_dir).problems
    assert not problems, "\n".join(problems)
