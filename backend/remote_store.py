"""Frames for workers without the shared volume: the content-addressed store over HTTP.

A worker on a machine that does not mount the service's frame store sets
`WHEELSCAN_STORE_URL` (the API's base URL) and `WHEELSCAN_STORE_TOKEN` (an operator token
made for it: `wheelscan token create --role operator --name worker-3`). `HttpBlobStore`
then reads and writes blobs through `/api/blobs/…` with the same methods as
`backend.storage.BlobStore`, keeps what it read in a local cache, and checks every blob's
sha256 both ways, so a truncated or altered transfer is an error, never a wrong frame.
"""

from __future__ import annotations

import hashlib

import httpx
from pydantic_settings import BaseSettings, SettingsConfigDict

from backend.storage import SHA256_PATTERN, BlobStore

BLOB_SUFFIXES = (".png", ".npz")
"""What the blob route serves: frames and measurement artefacts."""


class RemoteStoreSettings(BaseSettings):
    """Where a worker's frame store is, when it is not on a shared volume."""

    model_config = SettingsConfigDict(env_prefix="WHEELSCAN_", frozen=True)

    store_url: str | None = None
    store_token: str | None = None
    store_timeout_s: float = 60.0


class BlobIntegrityError(OSError):
    """A blob's bytes do not hash to its name."""


class HttpBlobStore:
    """A `BlobStore` read and written through the service's `/api/blobs` route.

    Parameters
    ----------
    base_url : str
        The service, e.g. "http://api:8000".
    token : str
        An operator token.
    cache : BlobStore
        Local store of the blobs read or written (its `root` is this store's root).
    client : httpx.Client, optional
        For tests (e.g. a FastAPI TestClient); default: a new client for `base_url`.
    """

    def __init__(
        self,
        base_url: str,
        token: str,
        cache: BlobStore,
        *,
        timeout_s: float = 60.0,
        client: httpx.Client | None = None,
    ) -> None:
        if not base_url.startswith(("http://", "https://")):
            raise ValueError(f"base_url must start with http:// or https://, got {base_url!r}")
        if not token:
            raise ValueError("token must be an operator token, got an empty one")
        self._client = client or httpx.Client(base_url=base_url, timeout=timeout_s)
        self._headers = {"Authorization": f"Bearer {token}"}
        self._cache = cache
        self.root = cache.root

    def path_for(self, sha256: str, suffix: str) -> str:
        """The blob's URL path on the service."""
        _check_name(sha256, suffix)
        return f"/api/blobs/{sha256}{suffix}"

    def put(self, data: bytes, suffix: str) -> str:
        """Send `data` to the service (a no-op there when it has it) and return its sha256."""
        sha256 = self._cache.put(data, suffix)
        response = self._client.put(
            self.path_for(sha256, suffix),
            content=data,
            headers={**self._headers, "Content-Type": "application/octet-stream"},
        )
        response.raise_for_status()
        return sha256

    def get(self, sha256: str, suffix: str) -> bytes:
        """The blob's bytes, from the local cache or the service (FileNotFoundError when the
        service has no such blob, BlobIntegrityError when the bytes do not match)."""
        if self._cache.has(sha256, suffix):
            return self._cache.get(sha256, suffix)
        response = self._client.get(self.path_for(sha256, suffix), headers=self._headers)
        if response.status_code == 404:
            raise FileNotFoundError(f"blob {sha256}{suffix} is not in the service's store")
        response.raise_for_status()
        data = response.content
        actual = hashlib.sha256(data).hexdigest()
        if actual != sha256:
            raise BlobIntegrityError(
                f"blob {sha256}{suffix}: received {len(data)} bytes hashing to {actual}"
            )
        self._cache.put(data, suffix)
        return data

    def has(self, sha256: str, suffix: str) -> bool:
        """Whether the service (or the local cache) has the blob."""
        if self._cache.has(sha256, suffix):
            return True
        response = self._client.head(self.path_for(sha256, suffix), headers=self._headers)
        if response.status_code == 404:
            return False
        response.raise_for_status()
        return True


def _check_name(sha256: str, suffix: str) -> None:
    if not SHA256_PATTERN.match(sha256):
        raise ValueError(f"sha256 must be 64 lowercase hex digits, got {sha256!r}")
    if suffix not in BLOB_SUFFIXES:
        raise ValueError(f"suffix must be one of {', '.join(BLOB_SUFFIXES)}, got {suffix!r}")


def make_worker_store(frames_dir_cache: BlobStore) -> BlobStore | HttpBlobStore:
    """The store a worker measures from: over HTTP when `WHEELSCAN_STORE_URL` is set, else
    the (shared) local folder."""
    remote = RemoteStoreSettings()
    if not remote.store_url:
        return frames_dir_cache
    if not remote.store_token:
        raise ValueError("WHEELSCAN_STORE_URL is set: WHEELSCAN_STORE_TOKEN must be too")
    return HttpBlobStore(
        remote.store_url, remote.store_token, frames_dir_cache, timeout_s=remote.store_timeout_s
    )
