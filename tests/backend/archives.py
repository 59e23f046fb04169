"""Small pass archives for the service tests: valid ones and each kind of broken one."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np

from pipeline.archive.pass_archive import encode_frame, write_pass_archive
from pipeline.calibration.model import calibration_to_document
from tests.pipeline.archive_helpers import small_calibration, small_frames, small_manifest


def small_archive_bytes(tmp_path: Path, *, with_calibration: bool = True) -> bytes:
    """A valid one-axle pass of 40x30 px frames."""
    manifest = small_manifest()
    out = tmp_path / "pass.zip"
    write_pass_archive(
        out,
        manifest,
        small_frames(manifest),
        calibration=small_calibration() if with_calibration else None,
    )
    return out.read_bytes()


def calibration_document() -> dict:
    return calibration_to_document(small_calibration())


def rewrite_zip(
    data: bytes, replace: dict[str, bytes | None], add: dict[str, bytes] | None = None
) -> bytes:
    """The archive with members replaced (None removes one) and members added."""
    out = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(data)) as source, zipfile.ZipFile(out, "w") as target:
        for info in source.infolist():
            if info.filename in replace:
                if replace[info.filename] is not None:
                    target.writestr(info.filename, replace[info.filename])
            else:
                target.writestr(info, source.read(info))
        for name, content in (add or {}).items():
            target.writestr(name, content)
    return out.getvalue()


def zip_bomb_bytes() -> bytes:
    """A zip whose one member inflates about 1000-fold."""
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("manifest.json", b"\0" * 900_000)
    return out.getvalue()


def manifest_of(data: bytes) -> dict:
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        return json.loads(archive.read("manifest.json"))


def frame_png(shape: tuple[int, int] = (30, 40), dtype: type = np.uint8, row: int = 15) -> bytes:
    frame = np.zeros(shape, dtype)
    frame[row, :] = 200
    return encode_frame(frame)
