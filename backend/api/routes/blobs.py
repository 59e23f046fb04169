"""Raw blobs of the content-addressed store, for workers without the shared volume
(`backend.storage.remote.HttpBlobStore`); operator tokens only."""

from __future__ import annotations

import hashlib
from typing import Annotated

from fastapi import APIRouter, Path, Request, Response
from starlette.concurrency import run_in_threadpool

from backend.api.deps import OperatorDep, StoreDep
from backend.errors import ERROR_RESPONSES, InvalidInputError, NotFoundError
from backend.storage.remote import BLOB_SUFFIXES

router = APIRouter(prefix="/api/blobs", tags=["blobs"], responses=ERROR_RESPONSES)

BlobName = Annotated[
    str,
    Path(
        pattern=r"^[0-9a-f]{64}\.(png|npz)$",
        description="sha256 of the bytes and the suffix: <64 hex digits>.png or .npz",
    ),
]


def _split(name: str) -> tuple[str, str]:
    sha256, suffix = name[:64], name[64:]
    if suffix not in BLOB_SUFFIXES:
        raise InvalidInputError(f"suffix must be one of {', '.join(BLOB_SUFFIXES)}")
    return sha256, suffix


@router.get("/{name}", response_class=Response)
def get_blob(name: BlobName, store: StoreDep, _operator: OperatorDep) -> Response:
    """The blob's bytes exactly as stored (a worker checks their sha256)."""
    sha256, suffix = _split(name)
    if not store.has(sha256, suffix):
        raise NotFoundError(f"blob {name} is not in the store")
    return Response(store.get(sha256, suffix), media_type="application/octet-stream")


@router.head("/{name}", response_class=Response)
def head_blob(name: BlobName, store: StoreDep, _operator: OperatorDep) -> Response:
    """200 when the blob is stored, 404 otherwise."""
    sha256, suffix = _split(name)
    if not store.has(sha256, suffix):
        raise NotFoundError(f"blob {name} is not in the store")
    return Response(media_type="application/octet-stream")


@router.put("/{name}", status_code=204, response_class=Response)
async def put_blob(
    name: BlobName,
    request: Request,
    store: StoreDep,
    _operator: OperatorDep,
) -> Response:
    """Store a blob (a no-op when stored); its bytes must hash to its name (422 otherwise)."""
    sha256, suffix = _split(name)
    data = await request.body()  # at most max_frame_bytes (BodySizeLimit)
    actual = hashlib.sha256(data).hexdigest()
    if actual != sha256:
        raise InvalidInputError(f"the body hashes to {actual}, not to the name's {sha256}")
    await run_in_threadpool(store.put, data, suffix)
    return Response(status_code=204)
