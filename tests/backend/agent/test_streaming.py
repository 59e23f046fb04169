"""The agent against the real server (uvicorn subprocess): emulated cameras replay a simulated
pass; the server ends up with exactly the archive's frames, through a SIGKILL and restart of
the server mid-pass, with a camera missing, and refuses bad tokens in one line."""

from __future__ import annotations

import hashlib
import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import cv2
import httpx
import numpy as np
import pytest

from backend.agent.capture import encode_png
from backend.agent.client import StreamClient
from backend.agent.replay import write_replay_station
from backend.agent.spool import PassOpen, Spool
from pipeline.calibration.model import calibration_to_document
from pipeline.simulation.station import build_station
from tests.backend.agent.live_server import LiveServer, free_port

FRAMES_PER_SENSOR = 2
DEADLINE_S = 240.0
TERMINAL = ("measured", "not_measured", "failed")


@pytest.fixture(scope="module")
def sim_pass(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One simulated vehicle, 2 axles, 2 frames per sensor and wheel (16 frames)."""
    out = tmp_path_factory.mktemp("sim") / "pass"
    command = [sys.executable, "-m", "backend.cli", "synth-pass", str(out), "--field", "clean"]
    command += ["--vehicles", "1", "--axles", "2", "--frames-per-sensor", str(FRAMES_PER_SENSOR)]
    subprocess.run(command, check=True, capture_output=True)
    return out


@pytest.fixture
def server(tmp_path: Path) -> Iterator[LiveServer]:
    live = LiveServer(tmp_path / "data")
    live.start()
    yield live
    live.stop()


@pytest.fixture(scope="module")
def shared_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """One server for the tests that leave no pass behind (or one of their own site)."""
    live = LiveServer(tmp_path_factory.mktemp("shared") / "data")
    live.start()
    yield live
    live.stop()


def agent_command(station: Path, server: LiveServer, token: str, *extra: str) -> list[str]:
    command = [sys.executable, "-m", "backend.cli", "agent", "--server", server.url]
    return [*command, "--token", token, "--station", str(station), *extra]


def agent_env(cameras: int = 4) -> dict[str, str]:
    return {**os.environ, "PYLON_CAMEMU": str(cameras)}


def run_agent(station: Path, server: LiveServer, *extra: str, cameras: int = 4, token=None):
    token = server.tokens["operator"] if token is None else token
    return subprocess.run(
        agent_command(station, server, token, *extra),
        env=agent_env(cameras),
        capture_output=True,
        text=True,
        timeout=DEADLINE_S,
        check=False,
    )


def expected_frames(station_dir: Path) -> set[tuple[str, int, str]]:
    """(sensor, seq, sha256) of the replayed files' pixels as the agent encodes them: seq n is
    the n-th file a camera replays (PNG encoding is deterministic and lossless, so equal
    hashes mean equal pixels)."""
    return {
        (folder.name, int(png.stem), hashlib.sha256(encode_png(read_png(png))).hexdigest())
        for folder in (station_dir / "replay").iterdir()
        for png in folder.glob("*.png")
    }


def read_png(path: Path) -> np.ndarray:
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def only_pass(server: LiveServer) -> dict:
    page = httpx.get(f"{server.url}/api/passes", headers=server.headers("viewer")).json()
    assert page["total"] == 1, page
    return page["items"][0]


def stored_frames(server: LiveServer, pass_id: int) -> list[tuple[str, int, str]]:
    rows = httpx.get(f"{server.url}/api/passes/{pass_id}/frames", headers=server.headers()).json()
    return [(r["sensor"], r["seq"], r["sha256"]) for r in rows]


def wheels(server: LiveServer, pass_id: int) -> list[dict]:
    url = f"{server.url}/api/passes/{pass_id}/wheels"
    return httpx.get(url, headers=server.headers("viewer")).json()


def measured_wheels(server: LiveServer, pass_id: int) -> dict[tuple, dict]:
    """Wheels of a pass once its job is done (every wheel measured or not, back-to-back
    distances written), keyed by identity, ids left out."""
    deadline = time.monotonic() + DEADLINE_S
    url = f"{server.url}/api/passes/{pass_id}"
    while (job := httpx.get(url, headers=server.headers("viewer")).json()["job"])[
        "state"
    ] != "done":
        assert time.monotonic() < deadline, job
        time.sleep(0.2)
    rows = wheels(server, pass_id)
    assert all(w["state"] in TERMINAL for w in rows), rows
    return {
        (w["vehicle_id"], w["axle"], w["side"]): {k: w[k] for k in w if k != "wheel_id"}
        for w in rows
    }


def upload_archive(server: LiveServer, folder: Path, zip_path: Path) -> int:
    with zipfile.ZipFile(zip_path, "w") as archive:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                archive.write(path, path.relative_to(folder).as_posix())
    with zip_path.open("rb") as stream:
        response = httpx.post(
            f"{server.url}/api/passes",
            headers=server.headers(),
            files={"file": (zip_path.name, stream, "application/zip")},
            timeout=DEADLINE_S,
        )
    assert response.status_code == 202, response.text
    return int(response.json()["pass_id"])


@pytest.mark.slow
def test_streamed_pass_holds_the_archives_frames_and_measures_like_its_upload(
    tmp_path: Path, sim_pass: Path, server: LiveServer
) -> None:
    station = write_replay_station(sim_pass, tmp_path / "station")
    result = run_agent(station, server)
    assert result.returncode == 0, result.stderr
    assert "1 passes, 16 frames captured, 0 declared missing, 16 sent" in result.stdout
    train_pass = only_pass(server)
    assert (train_pass["source"], train_pass["state"], train_pass["vehicles"]) == (
        "stream",
        "closed",
        ["V001"],
    )
    frames = stored_frames(server, train_pass["id"])
    assert len(frames) == len(set(frames))
    assert set(frames) == expected_frames(tmp_path / "station")
    streamed = measured_wheels(server, train_pass["id"])
    two = {"inner": FRAMES_PER_SENSOR, "outer": FRAMES_PER_SENSOR}
    assert {key: w["frames"] for key, w in streamed.items()} == {
        ("V001", axle, side): {f"{side}_{p}": n for p, n in two.items()}
        for axle in (1, 2)
        for side in ("left", "right")
    }
    uploaded = measured_wheels(server, upload_archive(server, sim_pass, tmp_path / "pass.zip"))
    assert streamed == uploaded
    assert {w["state"] for w in streamed.values()} == {"measured"}
    assert all(len(w["results"]) == 2 for w in streamed.values())


class AgentProcess:
    """The agent CLI in the background, its stderr lines collected as they come."""

    def __init__(self, command: list[str], env: dict[str, str]) -> None:
        self.process = subprocess.Popen(
            command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.lines: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.lines.put(line)

    def wait_for_line(self, text: str) -> None:
        deadline = time.monotonic() + DEADLINE_S
        while not any(text in line for line in self.seen):
            assert time.monotonic() < deadline, f"agent never said {text!r}: {self.seen[-5:]}"
            self.seen.append(self.lines.get(timeout=DEADLINE_S))


def open_fifo_writer(fifo: Path, agent: AgentProcess) -> int:
    """Open the wheel-sensor FIFO for writing once the agent reads it."""
    deadline = time.monotonic() + DEADLINE_S
    while True:
        try:
            return os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
        except OSError:
            assert agent.process.poll() is None, "agent exited before reading its events"
            assert time.monotonic() < deadline
            time.sleep(0.05)


def test_server_killed_and_restarted_mid_pass_loses_and_duplicates_nothing(
    tmp_path: Path, sim_pass: Path, server: LiveServer
) -> None:
    station_dir = tmp_path / "station"
    station = write_replay_station(sim_pass, station_dir)
    fifo = station_dir / "axles.fifo"
    os.mkfifo(fifo)
    data = json.loads(station.read_text())
    data["wheel_sensor"]["source"] = f"file:{fifo}"
    station.write_text(json.dumps(data))
    agent = AgentProcess(agent_command(station, server, server.tokens["operator"]), agent_env())
    writer = open_fifo_writer(fifo, agent)
    os.write(writer, b'{"event": "axle"}\n')
    agent.wait_for_line("is server pass 1")
    deadline = time.monotonic() + DEADLINE_S
    while len(stored_frames(server, 1)) < 4 * FRAMES_PER_SENSOR:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    server.kill()
    os.write(writer, b'{"event": "axle"}\n{"event": "end"}\n')
    os.close(writer)
    agent.wait_for_line("server unavailable, buffering frames on disk")
    server.start()
    assert agent.process.wait(timeout=DEADLINE_S) == 0, agent.seen
    frames = stored_frames(server, 1)
    assert len(frames) == len(set(frames)) == 16
    assert set(frames) == expected_frames(station_dir)
    assert only_pass(server)["state"] == "closed"
    assert list((station_dir / "spool").iterdir()) == []


def test_a_removed_camera_makes_its_wheels_not_measured_and_the_pass_goes_on(
    tmp_path: Path, sim_pass: Path, server: LiveServer
) -> None:
    station = write_replay_station(sim_pass, tmp_path / "station")
    refused = run_agent(station, server, cameras=3)
    assert refused.returncode == 2
    assert refused.stderr.strip().splitlines()[-1] == (
        "wheelscan agent: error: camera '0815-0003' for right_outer is not attached "
        "(cameras seen: 0815-0000, 0815-0001, 0815-0002)"
    )
    result = run_agent(station, server, "--allow-missing-cameras", cameras=3)
    assert result.returncode == 0, result.stderr
    assert "12 frames captured, 2 declared missing" in result.stdout
    assert only_pass(server)["state"] == "closed"
    by_side = {}
    for wheel in wheels(server, 1):
        by_side.setdefault(wheel["side"], []).append(wheel)
    for wheel in by_side["right"]:
        assert wheel["state"] == "not_measured"
        assert "right_outer" in wheel["reason"] and "is not attached" in wheel["reason"]
        assert wheel["missing_sensors"] == ["right_outer"]
    for wheel in by_side["left"]:
        assert wheel["frames"] == {"left_inner": 2, "left_outer": 2}
        assert wheel["state"] != "not_measured"


@pytest.mark.parametrize(
    ("role", "message"),
    [
        (None, "server refused the token (401: "),
        ("viewer", "token has role 'viewer'; streaming needs role operator"),
    ],
)
def test_a_refused_token_is_one_line(
    tmp_path: Path, sim_pass: Path, shared_server: LiveServer, role: str | None, message: str
) -> None:
    server = shared_server
    station = write_replay_station(sim_pass, tmp_path / "station")
    token = "wrong-token" if role is None else server.tokens[role]
    result = run_agent(station, server, token=token)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith(f"wheelscan agent: error: {message}")


def _signalled_once_spooled(agent: AgentProcess, station_dir: Path, signum: int) -> int:
    """Send `signum` to an agent whose server is away once its 16 frames are spooled; its
    exit status (the agent is killed if it does not end within DEADLINE_S)."""
    agent.wait_for_line("buffering frames until it answers")
    deadline = time.monotonic() + DEADLINE_S
    while len(list((station_dir / "spool").glob("*/f-*.json"))) < 16:
        assert time.monotonic() < deadline and agent.process.poll() is None
        time.sleep(0.05)
    agent.process.send_signal(signum)
    try:
        return agent.process.wait(timeout=DEADLINE_S)
    finally:
        agent.process.kill()


def test_frames_buffered_while_the_server_is_down_are_sent_by_the_next_run(
    tmp_path: Path, sim_pass: Path, server: LiveServer
) -> None:
    station_dir = tmp_path / "station"
    station = write_replay_station(sim_pass, station_dir)
    server.kill()
    agent = AgentProcess(agent_command(station, server, server.tokens["operator"]), agent_env())
    assert _signalled_once_spooled(agent, station_dir, signal.SIGINT) == 130
    server.start()
    (station_dir / "axles.jsonl").write_text("")
    result = run_agent(station, server)
    assert result.returncode == 0, result.stderr
    assert "resuming 16 buffered items" in result.stderr
    assert "0 passes, 0 frames captured, 0 declared missing, 16 sent" in result.stdout
    frames = stored_frames(server, 1)
    assert len(frames) == len(set(frames)) == 16
    assert set(frames) == expected_frames(station_dir)
    assert only_pass(server)["state"] == "closed"


SIGINT_IN_PYLON_START = """
import os, signal, sys

class SigintOnImport:
    def find_spec(self, name, path=None, target=None):
        if name.startswith("swig_runtime_data"):  # tried by pypylon's C start-up, error cleared
            sys.meta_path.remove(self)
            sys.stderr.write("SIGINT inside pypylon's start-up\\n")
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, SigintOnImport())
from backend.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_ctrl_c_while_pypylon_starts_ends_the_agent_whose_server_is_away(
    tmp_path: Path, sim_pass: Path
) -> None:
    """Ctrl-C while the agent imports pypylon: the start-up of its C module tries to import
    SWIG's `swig_runtime_data4`, which does not exist, and clears the error, so a
    KeyboardInterrupt raised there was dropped and the agent, buffering for an absent server,
    ran on for ever. An import hook sends the signal at exactly that import."""
    station = write_replay_station(sim_pass, tmp_path / "station")
    command = [sys.executable, "-c", SIGINT_IN_PYLON_START, "agent", "--token", "t"]
    command += ["--server", f"http://127.0.0.1:{free_port()}", "--station", str(station)]
    agent = AgentProcess(command, agent_env())
    agent.wait_for_line("SIGINT inside pypylon's start-up")
    try:
        assert agent.process.wait(timeout=DEADLINE_S) == 130
    finally:
        agent.process.kill()
    agent.wait_for_line("wheelscan: interrupted")
    assert not any("Traceback" in line for line in agent.seen), agent.seen


SIGINT_IGNORED = """
import os, signal, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)  # as a shell without job control starts `cmd &`
os.execv(sys.executable, [sys.executable, "-m", "backend.cli", *sys.argv[1:]])
"""


@pytest.mark.parametrize(
    ("launch", "signum", "status", "said"),
    [
        (["-c", SIGINT_IGNORED], signal.SIGINT, 130, "interrupted"),
        (["-m", "backend.cli"], signal.SIGTERM, 143, "terminated"),
    ],
    ids=["ctrl-c-with-sigint-ignored", "sigterm"],
)
def test_a_stop_signal_ends_the_agent_whose_server_is_away_and_keeps_its_spool(
    tmp_path: Path, sim_pass: Path, launch: list[str], signum: int, status: int, said: str
) -> None:
    """The agent's run ends in order (cameras closed, threads stopped), the frames spooled
    while the server was away kept for the next run:

    - Ctrl-C where the agent was started with SIGINT ignored. A shell without job control
      starts a background command so, and exec keeps it: a station script's `wheelscan
      agent ... &`, and the agents of a test run started with `&`. Python leaves an ignored
      SIGINT ignored, and the agent took Ctrl-C only where SIGINT had its default handler:
      it ran on for ever (every thread idle, the main one in run_agent's drain loop), and
      the two SIGINT tests above hung at every run of a test session so started.
    - SIGTERM (a service manager's stop, `kill`), with status 143: it killed the process
      where it stood (status −15)."""
    station_dir = tmp_path / "station"
    station = write_replay_station(sim_pass, station_dir)
    command = [sys.executable, *launch, "agent", "--token", "t", "--station", str(station)]
    command += ["--server", f"http://127.0.0.1:{free_port()}"]
    agent = AgentProcess(command, agent_env())
    assert _signalled_once_spooled(agent, station_dir, signum) == status
    agent.wait_for_line(f"wheelscan: {said}")
    assert not any("Traceback" in line for line in agent.seen), agent.seen
    assert Spool(station_dir / "spool", 2**30).waiting() == 16


def test_an_open_whose_answer_was_lost_finds_its_pass_instead_of_opening_another(
    shared_server: LiveServer,
) -> None:
    server = shared_server
    calibration = calibration_to_document(build_station().calibration)
    request = PassOpen("site-a", "2026-11-23T22:00:00.123456+00:00", "up", None, 1, calibration)
    client = StreamClient(server.url, server.tokens["operator"])
    try:
        assert client.find_pass(request) is None
        pass_id = client.open_pass(request)
        assert client.find_pass(request) == pass_id
        later = PassOpen("site-a", "2026-11-23T22:00:01+00:00", "up", None, 1, calibration)
        assert client.find_pass(later) is None
        client.close_pass(pass_id)
        assert client.find_pass(request) is None  # closed: a retry opens a new one
    finally:
        client.close()
