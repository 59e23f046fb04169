"""The station file: TOML or JSON, every fault reported in one line naming the key."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from backend.agent.station import StationError, load_station

TOML = """
site = "ZW-01"
server = "http://127.0.0.1:8000/"
frames_per_wheel = 2
image_width_px = 1600
image_height_px = 1200
spool_dir = "spool"

[wheel_sensor]
source = "tcp://127.0.0.1:7001"

[tag_reader]
source = "file:/run/tags.fifo"

[sensors.left_inner]
camera = "21234567"
exposure_us = 800
pixel_format = "Mono12"
trigger_source = "Line1"

[sensors.right_outer]
camera = "rail-right-outer"
"""


def minimal() -> dict[str, object]:
    return {
        "site": "s",
        "wheel_sensor": {"source": "file:/dev/null"},
        "sensors": {"left_inner": {"camera": "1"}},
    }


def write_json(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "station.json"
    path.write_text(json.dumps(data))
    return path


def test_toml_station_is_read_with_defaults_and_paths_beside_it(tmp_path: Path) -> None:
    path = tmp_path / "station.toml"
    path.write_text(TOML)
    station = load_station(path)
    assert station.site == "ZW-01"
    assert station.server == "http://127.0.0.1:8000"
    assert station.spool_dir == tmp_path.resolve() / "spool"
    assert station.tag_reader_source == "file:/run/tags.fifo"
    left, right = station.sensors
    assert (left.sensor, left.side, left.exposure_us, left.pixel_format) == (
        "left_inner",
        "left",
        800.0,
        "Mono12",
    )
    assert (right.sensor, right.camera, right.trigger_source, right.timeout_s) == (
        "right_outer",
        "rail-right-outer",
        "Line1",
        0.5,
    )


def test_json_station_is_read(tmp_path: Path) -> None:
    station = load_station(write_json(tmp_path, minimal()))
    assert station.frames_per_wheel == 1
    assert station.tag_reader_source is None
    assert [s.sensor for s in station.sensors] == ["left_inner"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"site": ""}, r"site must be a non-empty string"),
        ({"site": None}, r"missing site"),
        ({"frames_per_wheel": 0}, r"frames_per_wheel must be an integer 1\.\.64, got 0"),
        ({"spool_limit_mb": "big"}, r"spool_limit_mb must be a number"),
        ({"server": "127.0.0.1:8000"}, r"server must be an http:// or https:// URL"),
        ({"colour": "red"}, r"unknown key colour"),
        ({"wheel_sensor": {"source": "com1"}}, r"wheel_sensor.source must be 'file:/path' or"),
        ({"wheel_sensor": None}, r"missing \[wheel_sensor\] table"),
        ({"sensors": {}}, r"sensors must list at least one of"),
        ({"sensors": {"left_middle": {"camera": "1"}}}, r"unknown key sensors.left_middle"),
        ({"sensors": {"left_inner": {}}}, r"missing sensors.left_inner.camera"),
        (
            {"sensors": {"left_inner": {"camera": "1", "pixel_format": "RGB8"}}},
            r"sensors.left_inner.pixel_format must be one of Mono8, Mono10, Mono12, Mono16",
        ),
        (
            {"sensors": {"left_inner": {"camera": "1", "timeout_s": 0}}},
            r"sensors.left_inner.timeout_s must be within",
        ),
        (
            {"sensors": {"left_inner": {"camera": "1"}, "right_inner": {"camera": "1"}}},
            r"camera '1' is given for more than one sensor",
        ),
    ],
)
def test_bad_station_file_is_one_line_naming_the_key(
    tmp_path: Path, change: dict[str, object], message: str
) -> None:
    data = minimal()
    for key, value in change.items():
        if value is None:
            data.pop(key)
        else:
            data[key] = value
    with pytest.raises(StationError, match=message) as info:
        load_station(write_json(tmp_path, data))
    assert "\n" not in str(info.value)
    assert str(info.value).startswith(f"station file {tmp_path / 'station.json'}: ")


def test_unreadable_or_malformed_files_are_one_line(tmp_path: Path) -> None:
    with pytest.raises(StationError, match="cannot read"):
        load_station(tmp_path / "absent.toml")
    bad = tmp_path / "station.toml"
    bad.write_text("site = ")
    with pytest.raises(StationError, match="not valid toml"):
        load_station(bad)
    other = tmp_path / "station.yaml"
    other.write_text("site: s")
    with pytest.raises(StationError, match=r"must end in \.json or \.toml"):
        load_station(other)


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "backend.cli", "agent", *args]
    return subprocess.run(command, capture_output=True, text=True, check=False)


@pytest.mark.parametrize(
    ("data", "args", "message"),
    [
        ({**minimal(), "frames_per_wheel": "two"}, ["--token", "t"], "frames_per_wheel must be"),
        (minimal(), ["--token", "t"], "no server: give --server URL or 'server' in the station"),
        (minimal(), ["--server", "http://127.0.0.1:9", "--token", ""], "no token: give --token"),
    ],
)
def test_agent_cli_errors_are_one_line(
    tmp_path: Path, data: dict[str, object], args: list[str], message: str
) -> None:
    result = run_cli("--station", str(write_json(tmp_path, data)), *args)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert result.stderr.startswith("wheelscan agent: error: ")
    assert message in result.stderr


def test_agent_takes_its_token_from_wheelscan_token(tmp_path: Path) -> None:
    station = str(write_json(tmp_path, minimal()))
    command = [sys.executable, "-m", "backend.cli", "agent", "--station", station]
    command += ["--server", "http://127.0.0.1:9"]
    environment = {**os.environ, "WHEELSCAN_TOKEN": "wst_from_the_environment"}
    with_token = subprocess.run(command, capture_output=True, text=True, env=environment)
    # Past the token check (without a token it stops there, see above), the agent stops at
    # the first camera it cannot open.
    assert with_token.returncode == 2
    assert "camera '1' for left_inner is not attached" in with_token.stderr
