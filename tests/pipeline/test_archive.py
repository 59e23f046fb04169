"""Pass archive validation: every fault gets one clear ArchiveError; valid passes round-trip."""

from __future__ import annotations

import json
import os
import stat
import struct
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.archive.manifest import (
    manifest_to_document,
    parse_manifest,
)
from pipeline.archive.pass_archive import (
    ArchiveLimits,
    encode_frame,
    largest_png_bytes,
    png_header,
    read_pass_archive,
    write_pass_archive,
)
from pipeline.errors import ArchiveError
from tests.pipeline.archive_helpers import (
    many_frames_zip,
    padded_png,
    small_calibration,
    small_frames,
    small_manifest,
)


@pytest.fixture
def pass_folder(tmp_path: Path) -> Path:
    manifest = small_manifest()
    return write_pass_archive(
        tmp_path / "pass", manifest, small_frames(manifest), calibration=small_calibration()
    )


def _edit_manifest(folder: Path, edit) -> None:
    path = folder / "manifest.json"
    document = json.loads(path.read_text())
    edit(document)
    path.write_text(json.dumps(document))


def test_folder_round_trips_manifest_calibration_and_frames(pass_folder: Path) -> None:
    archive = read_pass_archive(pass_folder)
    assert archive.has_own_calibration
    assert archive.manifest.site == "test-site"
    assert [w.side for w in archive.manifest.wheels] == ["left", "right"]
    frame = archive.load_frame(archive.manifest.wheels[0].frames_inner[0])
    assert frame.dtype == np.uint8 and frame.shape == (30, 40) and frame[15, 3] == 200
    assert archive.calibration is not None
    assert archive.calibration.sensor("left_outer").plane_rms_mm == pytest.approx(0.02)


@pytest.mark.parametrize("as_bytes", [False, True])
def test_zip_file_and_zip_bytes_are_read_alike(tmp_path: Path, as_bytes: bool) -> None:
    manifest = small_manifest()
    frames = small_frames(manifest, np.uint16)
    out = write_pass_archive(
        tmp_path / "pass.zip", manifest, frames, calibration=small_calibration(16)
    )
    archive = read_pass_archive(out.read_bytes() if as_bytes else out)
    frame = archive.load_frame(manifest.wheels[1].frames_outer[0])
    assert frame.dtype == np.uint16 and frame[15, 0] == 200


def test_validation_has_no_side_effects(pass_folder: Path) -> None:
    before = sorted((p, p.stat().st_mtime_ns) for p in pass_folder.rglob("*"))
    read_pass_archive(pass_folder)
    assert sorted((p, p.stat().st_mtime_ns) for p in pass_folder.rglob("*")) == before


def test_site_calibration_is_used_when_the_archive_has_none(tmp_path: Path) -> None:
    manifest = small_manifest()
    folder = write_pass_archive(tmp_path / "p", manifest, small_frames(manifest))
    assert read_pass_archive(folder).calibration is None
    archive = read_pass_archive(folder, site_calibration=small_calibration())
    assert archive.calibration is not None and not archive.has_own_calibration
    with pytest.raises(ArchiveError, match="calibrated for 40x30 px 16 bit"):
        read_pass_archive(folder, site_calibration=small_calibration(16))


def test_manifest_document_round_trips() -> None:
    manifest = small_manifest()
    again = parse_manifest(manifest_to_document(manifest))
    assert again.started_at == manifest.started_at
    assert [w.frames_outer for w in again.wheels] == [w.frames_outer for w in manifest.wheels]
    assert again.odometer_km == () and "odometer_km" not in manifest_to_document(manifest)


def test_manifest_carries_the_vehicles_odometer_readings() -> None:
    document = manifest_to_document(small_manifest()) | {"odometer_km": {"V1": 120_345.5}}
    manifest = parse_manifest(document)
    assert manifest.odometer_km == (("V1", 120_345.5),)
    assert manifest.odometer_of("V1") == 120_345.5 and manifest.odometer_of("V2") is None
    assert manifest_to_document(manifest)["odometer_km"] == {"V1": 120_345.5}


def test_missing_manifest(pass_folder: Path) -> None:
    (pass_folder / "manifest.json").unlink()
    with pytest.raises(ArchiveError, match="lacks manifest.json"):
        read_pass_archive(pass_folder)


def test_malformed_manifest_json(pass_folder: Path) -> None:
    (pass_folder / "manifest.json").write_text("{not json")
    with pytest.raises(ArchiveError, match="manifest.json is not valid JSON"):
        read_pass_archive(pass_folder)


def test_nonexistent_source(tmp_path: Path) -> None:
    with pytest.raises(ArchiveError, match="neither a folder nor a file"):
        read_pass_archive(tmp_path / "nothing")


def test_not_a_zip(tmp_path: Path) -> None:
    path = tmp_path / "pass.zip"
    path.write_bytes(b"hello")
    with pytest.raises(ArchiveError, match="not a readable zip"):
        read_pass_archive(path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("site"), "lacks 'site'"),
        (lambda d: d.update(speed_kmh="fast"), "speed_kmh must be a number"),
        (lambda d: d.update(speed_kmh=-3), r"speed_kmh must be in \(0, 400\]"),
        (lambda d: d.update(started_at="yesterday"), "started_at is not ISO 8601"),
        (lambda d: d.update(started_at="2026-11-23T12:00:00"), "must carry a time zone"),
        (lambda d: d.update(started_at="0001-01-01T00:00:00+14:00"), "out of range in UTC"),
        (lambda d: d.update(direction="x" * 41), "direction must be a non-empty string of ≤ 40"),
        (lambda d: d.update(site="a\x00b"), "site must not contain NUL"),
        (lambda d: d.update(vehicles=["V" * 101]), r"vehicles\[0\] must be a non-empty string"),
        (lambda d: d.update(format="other/2"), "format must be 'wheelscan-pass/1'"),
        (lambda d: d.update(vehicles=[]), "vehicles must be a non-empty list"),
        (lambda d: d.update(odometer_km=[1]), "odometer_km must be an object"),
        (lambda d: d.update(odometer_km={"V9": 1}), "odometer_km names 'V9', not in 'vehicles'"),
        (lambda d: d.update(odometer_km={"V1": "far"}), r"odometer_km\['V1'\] must be a number"),
        (
            lambda d: d.update(odometer_km={"V1": -1}),
            r"odometer_km\['V1'\] must be in \[0, 1e\+08\]",
        ),
        (lambda d: d["wheels"][0].update(side="middle"), "side must be 'left' or 'right'"),
        (lambda d: d["wheels"][0].update(axle=0), "axle must be an integer"),
        (lambda d: d["wheels"][0].update(vehicle_id="V9"), "'V9' is not in 'vehicles'"),
        (lambda d: d["wheels"][0]["frames"].update(middle=[]), "unknown sensor 'middle'"),
        (lambda d: d["wheels"][0].update(frames={"inner": [], "outer": []}), "lists no frames"),
        (lambda d: d["wheels"][1].update(side="left"), "wheel vehicle 'V1' axle 1 left twice"),
        (
            lambda d: d["wheels"][1]["frames"].update(inner=d["wheels"][0]["frames"]["inner"]),
            "lists frame 'frames/left_inner/000001.png' twice",
        ),
        (
            lambda d: d["wheels"][0]["frames"].update(inner=["../secret.png"]),
            "must not contain '..'",
        ),
        (
            lambda d: d["wheels"][0]["frames"].update(inner=["/etc/passwd"]),
            "must be a relative POSIX path",
        ),
        (
            lambda d: d["wheels"][0]["frames"].update(inner=["frames/nothere.png"]),
            "lists frame 'frames/nothere.png', which the archive lacks",
        ),
    ],
)
def test_manifest_faults_get_one_clear_message(pass_folder: Path, edit, message: str) -> None:
    _edit_manifest(pass_folder, edit)
    with pytest.raises(ArchiveError, match=message):
        read_pass_archive(pass_folder)


def test_frame_that_is_not_an_image(pass_folder: Path) -> None:
    (pass_folder / "frames/left_inner/000001.png").write_text("not a png")
    with pytest.raises(ArchiveError, match="is not a PNG image"):
        read_pass_archive(pass_folder)


def test_truncated_png_is_refused(pass_folder: Path) -> None:
    path = pass_folder / "frames/left_inner/000001.png"
    path.write_bytes(path.read_bytes()[:60])
    with pytest.raises(ArchiveError, match="truncated: it ends before its IEND"):
        read_pass_archive(pass_folder)


def test_png_whose_image_data_is_broken_is_refused_when_decoding(pass_folder: Path) -> None:
    path = pass_folder / "frames/left_inner/000001.png"
    data = bytearray(path.read_bytes())
    start = data.index(b"IDAT") + 4
    data[start : start + 8] = b"\xff" * 8  # chunk layout intact, zlib stream not
    path.write_bytes(bytes(data))
    read_pass_archive(pass_folder, decode_frames=False)  # the header is fine
    with pytest.raises(ArchiveError, match="not a decodable"):
        read_pass_archive(pass_folder)


def test_a_frame_padded_with_chunks_beyond_its_pixels_is_refused(pass_folder: Path) -> None:
    # A 135 kB upload of 40x30 px frames each padded with 4 MiB of zeros stored 16.8 MB.
    frame = encode_frame(np.zeros((30, 40), np.uint8))
    largest = largest_png_bytes(40, 30, 8)
    fitting = padded_png(frame, largest - len(frame) - 12)
    assert png_header(fitting, "f") == (40, 30, 8)  # metadata within the room is kept
    with pytest.raises(ArchiveError, match=f"is {largest + 1} bytes, more than a 40x30 px 8 bit"):
        png_header(padded_png(frame, largest - len(frame) - 11), "f")
    path = pass_folder / "frames/left_inner/000001.png"
    path.write_bytes(padded_png(path.read_bytes(), 4 * 2**20))
    with pytest.raises(ArchiveError, match="send the frame without padding chunks"):
        read_pass_archive(pass_folder, decode_frames=False)


def test_every_encoded_frame_fits_its_largest_png(pass_folder: Path) -> None:
    # Noise does not compress: the encoder's output is the largest a real frame gets.
    noise = np.random.default_rng(1).integers(0, 2**16, (120, 160), dtype=np.uint16)
    for image in (noise, (noise >> 8).astype(np.uint8), noise[:1, :7]):
        data = encode_frame(image)
        depth = 8 * image.itemsize
        assert png_header(data, "f") == (image.shape[1], image.shape[0], depth)
        assert len(data) <= largest_png_bytes(image.shape[1], image.shape[0], depth)


def test_bytes_after_iend_are_refused(pass_folder: Path) -> None:
    path = pass_folder / "frames/left_inner/000001.png"
    path.write_bytes(path.read_bytes() + bytes(1000))
    with pytest.raises(ArchiveError, match="1000 bytes after its IEND chunk"):
        read_pass_archive(pass_folder, decode_frames=False)


def _claiming(data: bytes, width: int, height: int) -> bytes:
    """`data` (a PNG) whose IHDR claims width x height (CRCs are not checked before)."""
    return data[:16] + struct.pack(">II", width, height) + data[24:]


@pytest.mark.parametrize(("width", "height"), [(60000, 60000), (0, 30), (2**31, 1)])
def test_a_header_beyond_the_pixel_cap_is_refused_before_decoding(
    pass_folder: Path, width: int, height: int
) -> None:
    with pytest.raises(ArchiveError, match=f"claims {width}x{height} px"):
        png_header(_claiming(encode_frame(np.zeros((30, 40), np.uint8)), width, height), "f")


def test_a_frame_of_another_size_is_refused_by_its_header_not_decoded(
    pass_folder: Path,
) -> None:
    # 4000x3000 claimed by a small file: the header alone refuses it.
    path = pass_folder / "frames/left_inner/000001.png"
    path.write_bytes(_claiming(path.read_bytes(), 4000, 3000))
    with pytest.raises(ArchiveError, match="is 4000x3000 px 8 bit, but sensor left_inner"):
        read_pass_archive(pass_folder)


def test_colour_frame_is_refused(pass_folder: Path) -> None:
    colour = np.zeros((30, 40, 3), np.uint8)
    cv2.imwrite(str(pass_folder / "frames/left_inner/000001.png"), colour)
    with pytest.raises(ArchiveError, match="must be a grey PNG"):
        read_pass_archive(pass_folder)


def test_frame_of_wrong_size(pass_folder: Path) -> None:
    cv2.imwrite(str(pass_folder / "frames/right_outer/000001.png"), np.zeros((31, 40), np.uint8))
    with pytest.raises(ArchiveError, match="is 40x31 px 8 bit, but sensor right_outer"):
        read_pass_archive(pass_folder)


def test_frame_of_wrong_bit_depth(pass_folder: Path) -> None:
    cv2.imwrite(str(pass_folder / "frames/right_outer/000001.png"), np.zeros((30, 40), np.uint16))
    with pytest.raises(ArchiveError, match="is 40x30 px 16 bit"):
        read_pass_archive(pass_folder)


def test_invalid_calibration_in_archive(pass_folder: Path) -> None:
    path = pass_folder / "calibration.json"
    document = json.loads(path.read_text())
    document["sensors"]["middle"] = document["sensors"]["left_inner"]
    path.write_text(json.dumps(document))
    with pytest.raises(ArchiveError, match="calibration.json in the archive: .*unknown sensor"):
        read_pass_archive(pass_folder)


def test_sensor_without_calibration(pass_folder: Path) -> None:
    path = pass_folder / "calibration.json"
    document = json.loads(path.read_text())
    del document["sensors"]["right_outer"]
    path.write_text(json.dumps(document))
    with pytest.raises(ArchiveError, match="sensor right_outer, which is not calibrated"):
        read_pass_archive(pass_folder)


def test_symlinked_frame_in_folder_is_refused(pass_folder: Path, tmp_path: Path) -> None:
    outside = tmp_path / "outside.png"
    frame = pass_folder / "frames/left_inner/000001.png"
    outside.write_bytes(frame.read_bytes())
    frame.unlink()
    os.symlink(outside, frame)
    with pytest.raises(ArchiveError, match="symlinks are refused"):
        read_pass_archive(pass_folder)


def _zip_from_folder(folder: Path, out: Path, extra=()) -> Path:
    with zipfile.ZipFile(out, "w") as archive:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                archive.write(path, path.relative_to(folder).as_posix())
        for info, data in extra:
            archive.writestr(info, data)
    return out


@pytest.mark.parametrize(
    ("name", "message"),
    [("../evil.txt", r"must not contain '\.\.'"), ("/abs/evil.txt", "relative POSIX path")],
)
def test_unsafe_zip_member_names(pass_folder: Path, tmp_path: Path, name, message) -> None:
    out = _zip_from_folder(pass_folder, tmp_path / "p.zip", [(zipfile.ZipInfo(name), b"x")])
    with pytest.raises(ArchiveError, match=message):
        read_pass_archive(out)


def test_symlink_member_in_zip(pass_folder: Path, tmp_path: Path) -> None:
    info = zipfile.ZipInfo("frames/link.png")
    info.external_attr = (stat.S_IFLNK | 0o777) << 16
    out = _zip_from_folder(pass_folder, tmp_path / "p.zip", [(info, b"/etc/passwd")])
    with pytest.raises(ArchiveError, match="symlinks are refused"):
        read_pass_archive(out)


def test_zip_bomb_compression_ratio(pass_folder: Path, tmp_path: Path) -> None:
    info = zipfile.ZipInfo("padding.bin")
    info.compress_type = zipfile.ZIP_DEFLATED
    out = _zip_from_folder(pass_folder, tmp_path / "p.zip", [(info, b"\0" * 2_000_000)])
    with pytest.raises(ArchiveError, match="suspicious compression ratio"):
        read_pass_archive(out)


def test_zip_member_count_limit(pass_folder: Path, tmp_path: Path) -> None:
    out = _zip_from_folder(pass_folder, tmp_path / "p.zip")
    with pytest.raises(ArchiveError, match="more than 3"):
        read_pass_archive(out, limits=ArchiveLimits(max_members=3))


def test_writer_refuses_a_manifest_frame_it_was_not_given(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="frames lacks"):
        write_pass_archive(tmp_path / "p", small_manifest(), {})


def test_validating_a_zip_reads_its_directory_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The zip was reopened for every member (its central directory parsed again each
    # time): 4,000 tiny frames took 55 s. The time is in benchmarks/hardening.py.
    out = many_frames_zip(tmp_path / "many.zip", 100)
    parsed = []
    parse = zipfile.ZipFile._RealGetContents  # type: ignore[attr-defined]

    def counted(archive: zipfile.ZipFile) -> None:
        parsed.append(archive)
        parse(archive)

    monkeypatch.setattr(zipfile.ZipFile, "_RealGetContents", counted)
    archive = read_pass_archive(out)
    archive.close()
    assert sum(len(w.frames_inner) + len(w.frames_outer) for w in archive.manifest.wheels) == 400
    assert len(parsed) == 1, f"the central directory was read {len(parsed)} times"


def test_a_png_of_a_hundred_thousand_empty_chunks_is_refused(pass_folder: Path) -> None:
    data = encode_frame(np.zeros((1200, 1600), np.uint8))  # room for 1.2 MB of chunks
    iend = data.rindex(b"IEND") - 4
    empty = struct.pack(">I4sI", 0, b"tEXt", 0)
    with pytest.raises(ArchiveError, match="more than 65536 PNG chunks"):
        png_header(data[:iend] + empty * 100_000 + data[iend:], "f")
