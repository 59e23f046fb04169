"""Workers without the shared volume read and write the frame store over the API, with an
operator token, and never accept bytes that do not hash to the blob's name."""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from backend.api.app import create_app
from backend.config import Settings
from backend.services.auth import create_token
from backend.storage.remote import BlobIntegrityError, HttpBlobStore
from backend.storage.store import BlobStore
from tests.scale.topology import free_port

FRAME = b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 8


@pytest.fixture
def service(tmp_path: Path) -> Iterator[TestClient]:
    with TestClient(create_app(Settings(data_dir=tmp_path / "service", workers=1))) as client:
        yield client
    client.app.state.engine.dispose()


def token(client: TestClient, role: str) -> str:
    with client.app.state.session_factory() as session:
        plaintext = create_token(session, role=role, name=f"remote store {role}")[1]
        session.commit()
    return plaintext


@pytest.fixture
def remote(service: TestClient, tmp_path: Path) -> HttpBlobStore:
    cache = tmp_path / "worker-cache"
    return HttpBlobStore("http://testserver", token(service, "operator"), cache, client=service)


def test_a_worker_reads_a_frame_the_service_stored_and_caches_it(service, remote) -> None:
    sha256 = service.app.state.store.put(FRAME, ".png")
    assert remote.has(sha256, ".png")
    assert remote.get(sha256, ".png") == FRAME
    assert BlobStore(remote.root).get(sha256, ".png") == FRAME


def test_what_a_worker_writes_lands_in_the_service_store(service, remote) -> None:
    artefact = b"PK\x03\x04 measurement artefact"
    sha256 = remote.put(artefact, ".npz")
    assert service.app.state.store.get(sha256, ".npz") == artefact


def test_a_missing_blob_is_absent_not_an_error(remote) -> None:
    absent = "0" * 64
    assert not remote.has(absent, ".png")
    with pytest.raises(FileNotFoundError, match="not in the service's store"):
        remote.get(absent, ".png")


def test_a_corrupted_blob_on_the_service_is_refused_by_the_worker(service, remote) -> None:
    sha256 = service.app.state.store.put(FRAME, ".png")
    service.app.state.store.path_for(sha256, ".png").write_bytes(FRAME[:-1])
    with pytest.raises(BlobIntegrityError, match="hashing to"):
        remote.get(sha256, ".png")
    assert not BlobStore(remote.root).has(sha256, ".png")


def test_the_service_refuses_bytes_that_do_not_hash_to_the_name(service) -> None:
    wrong = hashlib.sha256(b"something else").hexdigest()
    response = service.put(
        f"/api/blobs/{wrong}.png",
        content=FRAME,
        headers={
            "Authorization": f"Bearer {token(service, 'operator')}",
            "Content-Type": "application/octet-stream",
        },
    )
    assert response.status_code == 422
    assert "hashes to" in response.json()["detail"]


def test_a_viewer_token_cannot_read_raw_blobs(service) -> None:
    sha256 = service.app.state.store.put(FRAME, ".png")
    response = service.get(
        f"/api/blobs/{sha256}.png", headers={"Authorization": f"Bearer {token(service, 'viewer')}"}
    )
    assert response.status_code == 403


def test_an_unreachable_service_is_a_connection_error_the_task_retries(tmp_path) -> None:
    unreachable = HttpBlobStore(f"http://127.0.0.1:{free_port()}", "wst_x", tmp_path / "cache")
    with pytest.raises(ConnectionError, match="frame store http://127.0.0.1"):
        unreachable.get("0" * 64, ".png")


def test_only_frames_and_artefacts_are_served(service) -> None:
    response = service.get(
        f"/api/blobs/{'a' * 64}.txt",
        headers={"Authorization": f"Bearer {token(service, 'operator')}"},
    )
    assert response.status_code == 422
