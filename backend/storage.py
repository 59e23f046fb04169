"""Content-addressed store for frames and measurement artefacts on disk.

A blob lives at `<root>/<sha[:2]>/<sha><suffix>`; writing the same bytes twice is a no-op,
and a write is atomic (temporary file in the same folder, fsync, rename), so a reader never
sees half a file and a crash never leaves one under a real name.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
from pathlib import Path

SHA256_PATTERN = re.compile(r"^[0-9a-f]{64}$")


class BlobStore:
    """Blobs addressed by the sha256 of their bytes."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)

    def path_for(self, sha256: str, suffix: str) -> Path:
        """Where the blob `sha256` with `suffix` lives (whether or not it exists)."""
        if not SHA256_PATTERN.match(sha256):
            raise ValueError(f"sha256 must be 64 lowercase hex digits, got {sha256!r}")
        return self.root / sha256[:2] / f"{sha256}{suffix}"

    def put(self, data: bytes, suffix: str) -> str:
        """Store `data` (once) and return its sha256."""
        sha256 = hashlib.sha256(data).hexdigest()
        path = self.path_for(sha256, suffix)
        if path.exists():
            return sha256
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".incoming-")
        try:
            with os.fdopen(handle, "wb") as stream:
                stream.write(data)
                stream.flush()
                os.fsync(stream.fileno())
            os.replace(temporary, path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
        return sha256

    def get(self, sha256: str, suffix: str) -> bytes:
        """The bytes of a stored blob (FileNotFoundError when absent)."""
        return self.path_for(sha256, suffix).read_bytes()

    def has(self, sha256: str, suffix: str) -> bool:
        """Whether the blob is stored."""
        return self.path_for(sha256, suffix).exists()
