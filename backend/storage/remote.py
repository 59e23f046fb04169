"""Frames for workers without the shared volume: the content-addressed store over HTTP.

A worker on a machine that does not mount the service's frame store sets
`WHEELSCAN_STORE_URL` (the API's base URL) and `WHEELSCAN_STORE_TOKEN` (an operator token
made for it: `wheelscan token create --role operator --name worker-3`). `HttpBlobStore`
then reads and writes blobs through `/api/blobs/…` with the same methods as
`backend.storage.store.BlobStore` (it is one, over a local cache), and checks every blob's
sha256 both ways, so a truncated or altered transfer is an error, never a wrong frame.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import httpx

from backend.config import Settings
from backend.storage.store import SHA256_PATTERN, BlobStore

BLOB_SUFFIXES = (".png", ".npz")
"""What the blob route serves: frames and measurement artefacts."""


class BlobIntegrityError(OSError):
    """A blob's bytes do not hash to its name."""


class HttpBlobStore(BlobStore):
    """A `BlobStore` read and written through the service's `/api/blobs` route, with a
    local cache under `cache_root` (where `path_for` points).

    Parameters
    ----------
    base_url : str
        The service, e.g. "http://api:8000".
    token : str
        An operator token.
    cache_root : Path
        Local store of the blobs read or written.
    timeout_s : float
        Per request.
    client : httpx.Client, optional
        For tests (e.g. a FastAPI TestClient); default: a new client for `base_url`.

    Notes
    -----
    A network fault (the service unreachable, a reset connection) is raised as
    `ConnectionError`, which the Celery task retries with backoff.
    """

    def __init__(
        self,
        base_url: str,
        token: str,
        cache_root: Path,
        *,
        timeout_s: float = 60.0,
        client: httpx.Client | None = None,
    ) -> None:
        if not base_url.startswith(("http://", "https://")):
            raise ValueError(f"base_url must start with http:// or https://, got {base_url!r}")
        if not token:
            raise ValueError("token must be an operator token, got an empty one")
        super().__init__(cache_root)
        self._client = client or httpx.Client(base_url=base_url, timeout=timeout_s)
        self._headers = {"Authorization": f"Bearer {token}"}

    def put(self, data: bytes, suffix: str) -> str:
        """Store `data` in the cache and on the service (a no-op there when it has it)."""
        sha256 = super().put(data, suffix)
        response = self._request(
            "PUT",
            sha256,
            suffix,
            content=data,
            headers={"Content-Type": "application/octet-stream"},
        )
        response.raise_for_status()
        return sha256

    def get(self, sha256: str, suffix: str) -> bytes:
        """The blob's bytes, from the cache or the service (FileNotFoundError when the
        service has no such blob, BlobIntegrityError when the bytes do not match)."""
        if super().has(sha256, suffix):
            return super().get(sha256, suffix)
        response = self._request("GET", sha256, suffix)
        if response.status_code == 404:
            raise FileNotFoundError(f"blob {sha256}{suffix} is not in the service's store")
        response.raise_for_status()
        data = response.content
        actual = hashlib.sha256(data).hexdigest()
        if actual != sha256:
            raise BlobIntegrityError(
                f"blob {sha256}{suffix}: received {len(data)} bytes hashing to {actual}"
            )
        super().put(data, suffix)
        return data

    def has(self, sha256: str, suffix: str) -> bool:
        """Whether the cache or the service has the blob."""
        if super().has(sha256, suffix):
            return True
        response = self._request("HEAD", sha256, suffix)
        if response.status_code == 404:
            return False
        response.raise_for_status()
        return True

    def _request(self, method: str, sha256: str, suffix: str, **options: Any) -> httpx.Response:
        _check_name(sha256, suffix)
        headers = {**self._headers, **options.pop("headers", {})}
        try:
            return self._client.request(
                method, f"/api/blobs/{sha256}{suffix}", headers=headers, **options
            )
        except httpx.TransportError as exc:
            raise ConnectionError(f"frame store {self._client.base_url}: {exc}") from exc


def _check_name(sha256: str, suffix: str) -> None:
    if not SHA256_PATTERN.match(sha256):
        raise ValueError(f"sha256 must be 64 lowercase hex digits, got {sha256!r}")
    if suffix not in BLOB_SUFFIXES:
        raise ValueError(f"suffix must be one of {', '.join(BLOB_SUFFIXES)}, got {suffix!r}")


def make_worker_store(settings: Settings) -> BlobStore:
    """The store a worker measures from: over HTTP, cached in `settings.frames_dir`, when
    `WHEELSCAN_STORE_URL` is set; else `settings.frames_dir` itself (the shared volume)."""
    frames_dir = settings.frames_dir
    if not settings.store_url:
        return BlobStore(frames_dir)
    if not settings.store_token:
        raise ValueError("WHEELSCAN_STORE_URL is set: WHEELSCAN_STORE_TOKEN must be too")
    return HttpBlobStore(
        settings.store_url, settings.store_token, frames_dir, timeout_s=settings.store_timeout_s
    )
