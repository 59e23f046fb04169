"""Pass archives `wheelscan-pass/1` (a folder or a .zip): strict validation, frames, writing.

`read_pass_archive` validates everything a measurement relies on and has no side effects, so
the service calls it on an upload before storing anything. Zips are treated as hostile:
member count, sizes and compression ratio are limited, and absolute paths, `..`, symlinks,
encrypted and duplicated members are refused. Frames are PNG, grey, 8 or 16 bit.

The format: docs/formats.md, "Pass archive".
"""

from __future__ import annotations

import io
import json
import stat
import struct
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.archive.manifest import (
    PassManifest,
    check_member_path,
    manifest_to_document,
    parse_manifest,
)
from pipeline.calibration.model import (
    MAX_FRAME_PIXELS,
    StationCalibration,
    calibration_to_document,
    load_calibration_json,
)
from pipeline.errors import ArchiveError, CalibrationError

MANIFEST_NAME = "manifest.json"
CALIBRATION_NAME = "calibration.json"
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MAX_PNG_CHUNKS = 2**16
"""Chunks of a frame at most: encoders write IDAT in 8–64 KiB chunks (a 64 MiB frame has at
most 8192), while 12-byte empty chunks would make a 32 MiB body 2.8 million of them."""
PNG_METADATA_BYTES = 64 * 2**10
"""Room beside the image data of a frame [bytes]: signature, IHDR, IEND, chunk headers and
text chunks. Anything else a file carries would be stored with the frame and never read."""


@dataclass(frozen=True, slots=True)
class ArchiveLimits:
    """Limits that keep a hostile archive from exhausting memory or disk.

    Attributes
    ----------
    max_members : int
        Entries in a zip (files and folders).
    max_member_bytes : int
        Uncompressed size of one member [bytes].
    max_total_bytes : int
        Uncompressed size of all members together [bytes].
    max_compression_ratio : float
        Uncompressed / compressed size of one member (PNG frames barely compress; a
        ratio above this is a zip bomb, not a pass).
    max_manifest_bytes : int
        Size of manifest.json [bytes].
    """

    max_members: int = 20_000
    max_member_bytes: int = 64 * 2**20
    max_total_bytes: int = 8 * 2**30
    max_compression_ratio: float = 200.0
    max_manifest_bytes: int = 8 * 2**20


DEFAULT_LIMITS = ArchiveLimits()


class _ZipSource:
    """Read access to a validated zip (from a path or bytes), opened once: reopening it per
    member parsed the central directory again each time (quadratic in the members)."""

    def __init__(self, source: Path | bytes, limits: ArchiveLimits) -> None:
        self._limits = limits
        try:
            opened = io.BytesIO(source) if isinstance(source, bytes) else source
            self._archive = zipfile.ZipFile(opened)
        except (zipfile.BadZipFile, OSError) as exc:
            raise ArchiveError(f"pass archive is not a readable zip: {exc}") from None
        try:
            self.sizes = _check_zip_members(self._archive.infolist(), limits)
        except ArchiveError:
            self._archive.close()
            raise

    def has(self, name: str) -> bool:
        return name in self.sizes

    def read(self, name: str) -> bytes:
        try:
            with self._archive.open(name) as member:
                data = member.read(self._limits.max_member_bytes + 1)
        except (zipfile.BadZipFile, OSError, EOFError, RuntimeError, ValueError) as exc:
            raise ArchiveError(f"archive member {name!r} cannot be read: {exc}") from None
        if len(data) > self._limits.max_member_bytes:
            raise ArchiveError(f"archive member {name!r} is larger than allowed")
        return data

    def close(self) -> None:
        self._archive.close()


class _FolderSource:
    """Read access to a pass folder, never leaving it (no symlinks, no `..`)."""

    def __init__(self, root: Path, limits: ArchiveLimits) -> None:
        self._root = root.resolve()
        self._limits = limits

    def has(self, name: str) -> bool:
        parts = name.split("/")
        for i in range(len(parts)):
            if self._root.joinpath(*parts[: i + 1]).is_symlink():
                raise ArchiveError(f"archive path {name!r} is a symlink; symlinks are refused")
        return self._root.joinpath(*parts).is_file()

    def read(self, name: str) -> bytes:
        if not self.has(name):
            raise ArchiveError(f"archive lacks {name!r}")
        path = self._root.joinpath(*name.split("/"))
        if path.stat().st_size > self._limits.max_member_bytes:
            raise ArchiveError(f"archive file {name!r} is larger than allowed")
        return path.read_bytes()

    def close(self) -> None:
        """Nothing is held open."""


def _check_zip_members(infos: list[zipfile.ZipInfo], limits: ArchiveLimits) -> dict[str, int]:
    if len(infos) > limits.max_members:
        raise ArchiveError(f"zip has {len(infos)} members, more than {limits.max_members}")
    sizes: dict[str, int] = {}
    total = 0
    for info in infos:
        name = info.filename
        if info.is_dir():
            continue
        check_member_path(name, "zip member name")
        if stat.S_ISLNK(info.external_attr >> 16):
            raise ArchiveError(f"zip member {name!r} is a symlink; symlinks are refused")
        if info.flag_bits & 0x1:
            raise ArchiveError(f"zip member {name!r} is encrypted")
        if name in sizes:
            raise ArchiveError(f"zip holds member {name!r} twice")
        if info.file_size > limits.max_member_bytes:
            raise ArchiveError(f"zip member {name!r} is larger than {limits.max_member_bytes} B")
        if info.file_size > limits.max_compression_ratio * max(info.compress_size, 1):
            raise ArchiveError(f"zip member {name!r} has a suspicious compression ratio")
        total += info.file_size
        if total > limits.max_total_bytes:
            raise ArchiveError(f"zip content is larger than {limits.max_total_bytes} B")
        sizes[name] = info.file_size
    return sizes


def png_header(data: bytes, name: str) -> tuple[int, int, int]:
    """(width, height, bit depth) of a grey 8/16-bit PNG from its IHDR, before decoding.

    Parameters
    ----------
    data : bytes
        The PNG file.
    name : str
        What the frame is, for the messages.

    Returns
    -------
    tuple of int
        Width [px], height [px] and bit depth [bits].

    Raises
    ------
    ArchiveError
        Not a PNG (signature, IHDR first), not grey, not 8 or 16 bit, more than
        `MAX_FRAME_PIXELS` pixels, larger than `largest_png_bytes` of its size, chunks
        running past the data, or bytes after IEND (they would be stored with the frame and
        never read).
    """
    if len(data) < 33 or not data.startswith(_PNG_SIGNATURE) or data[12:16] != b"IHDR":
        raise ArchiveError(f"frame {name!r} is not a PNG image")
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    if colour != 0:
        raise ArchiveError(f"frame {name!r} must be a grey PNG, got PNG colour type {colour}")
    if depth not in (8, 16):
        raise ArchiveError(f"frame {name!r} must be 8 or 16 bit, got {depth} bit")
    if not 0 < width * height <= MAX_FRAME_PIXELS:
        raise ArchiveError(
            f"frame {name!r} claims {width}x{height} px; frames have 1 to {MAX_FRAME_PIXELS} pixels"
        )
    largest = largest_png_bytes(width, height, depth)
    if len(data) > largest:
        raise ArchiveError(
            f"frame {name!r} is {len(data)} bytes, more than a {width}x{height} px {depth} bit "
            f"PNG needs ({largest} bytes stored uncompressed, with {PNG_METADATA_BYTES} bytes "
            "of metadata); send the frame without padding chunks"
        )
    _check_chunks(data, name)
    return width, height, depth


def largest_png_bytes(width_px: int, height_px: int, depth_bits: int) -> int:
    """Largest file a grey PNG of this size may be [bytes]: its filtered rows (a filter byte
    per row) plus 1/8 for a deflate stream that does not compress, plus PNG_METADATA_BYTES.

    A frame is stored as received; bounding it by its own pixels keeps a small upload of
    padded frames (chunks of zeros deflate about 1000-fold in a zip) from filling the disk.
    """
    raw_bytes = height_px * (1 + width_px * depth_bits // 8)
    return raw_bytes + raw_bytes // 8 + PNG_METADATA_BYTES


def _check_chunks(data: bytes, name: str) -> None:
    offset = len(_PNG_SIGNATURE)
    for _ in range(MAX_PNG_CHUNKS):
        if offset + 12 > len(data):
            raise ArchiveError(f"frame {name!r} is truncated: it ends before its IEND chunk")
        length, kind = struct.unpack_from(">I4s", data, offset)
        offset += 12 + length  # length, type, data, CRC
        if kind == b"IEND":
            if offset != len(data):
                raise ArchiveError(
                    f"frame {name!r} has {len(data) - offset} bytes after its IEND chunk; "
                    "send the PNG without trailing data"
                )
            return
    raise ArchiveError(f"frame {name!r} has more than {MAX_PNG_CHUNKS} PNG chunks")


def decode_frame(data: bytes, name: str) -> np.ndarray:
    """Decode PNG bytes into a 2-D uint8 or uint16 frame; ArchiveError when it is not one."""
    png_header(data, name)
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None or image.ndim != 2 or image.dtype not in (np.uint8, np.uint16):
        raise ArchiveError(f"frame {name!r} is not a decodable grey 8/16-bit PNG image")
    return image


@dataclass(frozen=True, slots=True, eq=False)
class PassArchive:
    """A validated pass archive: its manifest, its own calibration (if any) and its frames.

    Attributes
    ----------
    manifest : PassManifest
    calibration : StationCalibration or None
        The archive's calibration.json, or the site calibration given to
        `read_pass_archive` when the archive has none; None when neither exists.
    has_own_calibration : bool
        True when the archive carries calibration.json.
    """

    manifest: PassManifest
    calibration: StationCalibration | None
    has_own_calibration: bool
    _source: _ZipSource | _FolderSource

    def frame_bytes(self, path: str) -> bytes:
        """The stored PNG bytes of frame `path` (for content-addressed storage)."""
        return self._source.read(path)

    def load_frame(self, path: str) -> np.ndarray:
        """Decode frame `path` into a 2-D uint8 or uint16 array [grey levels]."""
        return decode_frame(self._source.read(path), path)

    def close(self) -> None:
        """Close the zip (a folder holds nothing open)."""
        self._source.close()


def _open_source(source: str | Path | bytes, limits: ArchiveLimits) -> _ZipSource | _FolderSource:
    if isinstance(source, bytes | bytearray):
        return _ZipSource(bytes(source), limits)
    path = Path(source)
    if path.is_dir():
        return _FolderSource(path, limits)
    if path.is_file():
        return _ZipSource(path, limits)
    raise ArchiveError(f"pass archive {str(path)!r} is neither a folder nor a file")


def _read_json(source: _ZipSource | _FolderSource, name: str, limit: int) -> object:
    data = source.read(name)
    if len(data) > limit:
        raise ArchiveError(f"{name} is larger than {limit} bytes")
    try:
        return json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ArchiveError(f"{name} is not valid JSON: {exc}") from None


def _check_frames(
    archive: PassArchive, *, decode_frames: bool, listed: list[tuple[str, str]]
) -> None:
    """Check every listed frame exists, is a grey PNG, and fits its sensor's calibration."""
    seen: dict[str, tuple[int, int, int, str]] = {}
    for sensor, path in listed:
        data = archive.frame_bytes(path)
        width, height, depth = png_header(data, path)
        if archive.calibration is not None:
            cal = archive.calibration.sensor(sensor)
            expected = (cal.image_width_px, cal.image_height_px, cal.bit_depth)
            if (width, height, depth) != expected:
                raise ArchiveError(
                    f"frame {path!r} is {width}x{height} px {depth} bit, but sensor {sensor} "
                    f"is calibrated for {expected[0]}x{expected[1]} px {expected[2]} bit"
                )
        first = seen.setdefault(sensor, (width, height, depth, path))
        if first[:3] != (width, height, depth):
            raise ArchiveError(
                f"frame {path!r} ({width}x{height} px {depth} bit) differs from {first[3]!r} "
                f"of the same sensor {sensor}"
            )
        if decode_frames:  # only once the header fits: never decode what is refused anyway
            decode_frame(data, path)


def read_pass_archive(
    source: str | Path | bytes,
    *,
    site_calibration: StationCalibration | None = None,
    decode_frames: bool = True,
    limits: ArchiveLimits = DEFAULT_LIMITS,
) -> PassArchive:
    """Validate a `wheelscan-pass/1` archive and return it, without side effects.

    Parameters
    ----------
    source : str, Path or bytes
        A pass folder, a .zip file, or the bytes of a .zip.
    site_calibration : StationCalibration, optional
        The site's registered calibration, used when the archive has no calibration.json.
    decode_frames : bool
        Also decode every frame fully (not only its PNG header).
    limits : ArchiveLimits
        Size and count limits for hostile zips.

    Returns
    -------
    PassArchive

    Raises
    ------
    ArchiveError
        One clear message for the first fault: not a folder/zip, unsafe member (absolute
        path, `..`, symlink, encrypted, zip bomb), missing or malformed manifest, unknown
        side or sensor, duplicated wheel, a listed frame missing or not a grey 8/16-bit PNG,
        a frame whose size or bit depth does not match its sensor's calibration, a sensor
        without calibration, or an invalid calibration.json.
    """
    src = _open_source(source, limits)
    try:
        if not src.has(MANIFEST_NAME):
            raise ArchiveError(f"pass archive lacks {MANIFEST_NAME}")
        manifest = parse_manifest(_read_json(src, MANIFEST_NAME, limits.max_manifest_bytes))
        calibration = site_calibration
        own = src.has(CALIBRATION_NAME)
        if own:
            try:
                calibration = load_calibration_json(src.read(CALIBRATION_NAME))
            except CalibrationError as exc:
                raise ArchiveError(f"{CALIBRATION_NAME} in the archive: {exc}") from None
        listed = [
            (wheel.sensor_name(position), path)
            for wheel in manifest.wheels
            for position in ("inner", "outer")
            for path in wheel.frames(position)
        ]
        for sensor, path in listed:
            if not src.has(path):
                raise ArchiveError(f"manifest lists frame {path!r}, which the archive lacks")
            if calibration is not None and sensor not in calibration.sensor_names:
                raise ArchiveError(
                    f"frame {path!r} is from sensor {sensor}, which is not calibrated"
                )
        archive = PassArchive(manifest, calibration, own, src)
        _check_frames(archive, decode_frames=decode_frames, listed=listed)
        return archive
    except BaseException:
        src.close()
        raise


def encode_frame(image: np.ndarray) -> bytes:
    """Encode a 2-D uint8/uint16 frame as PNG bytes (lossless)."""
    if image.ndim != 2 or image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"frame must be 2-D uint8 or uint16, got {image.dtype} {image.shape}")
    ok, buffer = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise ValueError("frame could not be PNG-encoded")
    return buffer.tobytes()


def write_pass_archive(
    out: str | Path,
    manifest: PassManifest,
    frames: Mapping[str, np.ndarray | bytes],
    *,
    calibration: StationCalibration | None = None,
) -> Path:
    """Write a pass as a folder, or as a zip when `out` ends in ".zip".

    Parameters
    ----------
    out : str or Path
        Target folder (created) or .zip file.
    manifest : PassManifest
    frames : mapping of str to ndarray or bytes
        Archive-relative path → frame (2-D uint8/uint16) or PNG bytes; every frame the
        manifest lists must be present.
    calibration : StationCalibration, optional
        Written as calibration.json when given.

    Returns
    -------
    Path
        `out`.
    """
    listed = {p for w in manifest.wheels for p in w.frames_inner + w.frames_outer}
    missing = sorted(listed - set(frames))
    if missing:
        raise ValueError(f"frames lacks {missing[0]!r}, which the manifest lists")
    members = {MANIFEST_NAME: json.dumps(manifest_to_document(manifest), indent=2).encode()}
    if calibration is not None:
        document = calibration_to_document(calibration)
        members[CALIBRATION_NAME] = json.dumps(document, indent=2).encode()
    for path, frame in frames.items():
        check_member_path(path, "frame path")
        members[path] = frame if isinstance(frame, bytes) else encode_frame(frame)
    out = Path(out)
    if out.suffix == ".zip":
        with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as archive:
            for name, data in members.items():
                archive.writestr(name, data)
        return out
    for name, data in members.items():
        target = out.joinpath(*name.split("/"))
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    return out
