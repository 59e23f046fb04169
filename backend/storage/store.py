"""Content-addressed store for frames and measurement artefacts on disk.

A blob lives at `<root>/<sha[:2]>/<sha><suffix>`; writing the same bytes twice is a no-op,
and a write is atomic (temporary file in the same folder, fsync, rename), so a reader never
sees half a file and a crash never leaves one under a real name. A temporary file names its
host and process; the next start removes those whose process is gone.

docs/service.md, "Storage".
"""

from __future__ import annotations

import hashlib
import os
import re
import socket
import tempfile
from pathlib import Path

SHA256_PATTERN = re.compile(r"^[0-9a-f]{64}$")
TEMPORARY_PREFIX = ".incoming-"
_TEMPORARY_NAME = re.compile(rf"^{re.escape(TEMPORARY_PREFIX)}(?P<host>.+)-(?P<pid>\d+)-[a-z0-9_]+")


def temporary_prefix() -> str:
    """Prefix of this process's temporary files: `.incoming-<host>-<pid>-`."""
    return f"{TEMPORARY_PREFIX}{socket.gethostname()}-{os.getpid()}-"


def _process_gone(pid: int) -> bool:
    if pid == os.getpid():
        return True  # an earlier process with our pid (a restarted container)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def remove_abandoned_temporaries(folder: Path) -> int:
    """Remove the temporary files under `folder` that a process of this host left when it
    died between writing and renaming (a crash); returns how many.

    Call it when the service starts, before this process writes: a file of a live process
    (a worker sharing the store) or of another host is left alone.
    """
    host = socket.gethostname()
    removed = 0
    for path in folder.rglob(f"{TEMPORARY_PREFIX}*") if folder.is_dir() else ():
        owner = _TEMPORARY_NAME.match(path.name)
        if owner and owner["host"] == host and _process_gone(int(owner["pid"])):
            path.unlink(missing_ok=True)
            removed += 1
    return removed


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
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=temporary_prefix())
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
