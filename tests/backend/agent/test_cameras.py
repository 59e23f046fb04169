"""pylon's camera emulation through PylonCamera: replayed PNG files arrive pixel for pixel."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from backend.agent.cameras import CameraError, GrabFailed, list_devices, open_cameras
from backend.agent.station import SENSORS, load_station

SIZE_PX = (40, 56)


def write_station(tmp_path: Path, sensors: dict[str, dict[str, object]]) -> Path:
    station = {
        "site": "s",
        "image_width_px": SIZE_PX[1],
        "image_height_px": SIZE_PX[0],
        "wheel_sensor": {"source": "file:/dev/null"},
        "sensors": sensors,
    }
    path = tmp_path / "station.json"
    path.write_text(json.dumps(station))
    return path


def replay_folder(tmp_path: Path, name: str, images: list[np.ndarray]) -> Path:
    folder = tmp_path / name
    folder.mkdir()
    for n, image in enumerate(images):
        cv2.imwrite(str(folder / f"{n:06d}.png"), image)
    return folder


def sensor(serial: str, folder: Path | None, pixel_format: str, trigger: str = "Software"):
    config = {"camera": serial, "pixel_format": pixel_format, "trigger_source": trigger}
    config["timeout_s"] = 0.3
    if folder is not None:
        config["replay_dir"] = str(folder)
    return config


def test_four_emulated_cameras_are_listed(emulated_cameras: int) -> None:
    devices = list_devices()
    assert [d.serial for d in devices] == [f"0815-000{n}" for n in range(4)]
    assert {d.device_class for d in devices} == {"BaslerCamEmu"}


@pytest.mark.parametrize(
    ("dtype", "top", "pixel_format", "shift"),
    [
        (np.uint8, 256, "Mono8", 0),
        (np.uint16, 65536, "Mono16", 0),
        (np.uint16, 4096, "Mono16", 0),
        (np.uint16, 65536, "Mono12", 4),
    ],
)
def test_emulated_cameras_deliver_the_replayed_files_pixels(
    tmp_path: Path, emulated_cameras: int, dtype: type, top: int, pixel_format: str, shift: int
) -> None:
    rng = np.random.default_rng(7)
    sets = {
        name: [rng.integers(0, top, SIZE_PX).astype(dtype) for _ in range(3)] for name in SENSORS
    }
    configs = {
        name: sensor(f"0815-000{n}", replay_folder(tmp_path, name, sets[name]), pixel_format)
        for n, name in enumerate(SENSORS)
    }
    cameras, missing = open_cameras(
        load_station(write_station(tmp_path, configs)), allow_missing=False
    )
    try:
        assert missing == {}
        for name in SENSORS:
            # Replay goes round the folder in file-name order: 4 grabs wrap to the first file.
            for k in range(4):
                image = cameras[name].grab()
                expected = sets[name][k % 3] >> shift
                assert image.dtype == dtype
                np.testing.assert_array_equal(image, expected)
    finally:
        for camera in cameras.values():
            camera.close()


def test_a_camera_without_trigger_times_out_with_a_reason(
    tmp_path: Path, emulated_cameras: int
) -> None:
    configs = {"left_inner": sensor("0815-0000", None, "Mono8", trigger="Line1")}
    cameras, _ = open_cameras(load_station(write_station(tmp_path, configs)), allow_missing=False)
    try:
        with pytest.raises(
            GrabFailed, match=r"left_inner \(0815-0000\) delivered no frame within 0.3 s"
        ) as info:
            cameras["left_inner"].grab()
        assert not info.value.lost
    finally:
        cameras["left_inner"].close()


def test_a_removed_camera_is_lost(tmp_path: Path, emulated_cameras: int) -> None:
    configs = {"left_inner": sensor("0815-0000", None, "Mono8")}
    cameras, _ = open_cameras(load_station(write_station(tmp_path, configs)), allow_missing=False)
    camera = cameras["left_inner"]
    camera.close()
    with pytest.raises(GrabFailed, match="left_inner") as info:
        camera.grab()
    assert info.value.lost


def test_a_camera_not_attached_is_a_one_line_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYLON_CAMEMU", "3")
    configs = {name: sensor(f"0815-000{n}", None, "Mono8") for n, name in enumerate(SENSORS)}
    station = load_station(write_station(tmp_path, configs))
    with pytest.raises(CameraError, match=r"^camera '0815-0003' for right_outer is not attached"):
        open_cameras(station, allow_missing=False)
    cameras, missing = open_cameras(station, allow_missing=True)
    for camera in cameras.values():
        camera.close()
    assert sorted(cameras) == sorted(SENSORS[:3])
    assert missing == {"right_outer": "camera '0815-0003' for right_outer is not attached"}


def test_replay_needs_an_emulated_camera_folder(tmp_path: Path, emulated_cameras: int) -> None:
    configs = {"left_inner": sensor("0815-0000", tmp_path / "nowhere", "Mono8")}
    with pytest.raises(CameraError, match="replay_dir .*nowhere is not a folder"):
        open_cameras(load_station(write_station(tmp_path, configs)), allow_missing=False)
