"""The disk spool: bounded, persistent across restarts, closes a pass only when drained."""

from __future__ import annotations

from pathlib import Path

from backend.agent.progress import Progress
from backend.agent.spool import CloseItem, FrameItem, MissingItem, PassOpen, Spool, SpoolItem

REQUEST = PassOpen("s", "2026-11-23T22:00:00+00:00", "up", 20.0, 1, None)


def test_declarations_follow_their_wheels_frames_and_close_comes_last(tmp_path: Path) -> None:
    spool = Spool(tmp_path, limit_bytes=1000)
    key = spool.begin_pass(REQUEST)
    assert spool.add_frame(key, "left_inner", 0, "v", 1, b"a" * 10)
    spool.add_missing(key, "v", 1, "left", "left_outer", "camera gone")
    assert spool.add_frame(key, "right_inner", 0, "v", 1, b"b" * 10)
    first = spool.take(0)
    assert isinstance(first, FrameItem) and (first.sensor, first.seq) == ("left_inner", 0)
    second = spool.take(0)
    assert isinstance(second, FrameItem) and second.sensor == "right_inner"
    assert spool.take(0) is None  # the axle is still being captured
    spool.release_axle(key, "v", 1)
    assert spool.take(0) is None  # the wheel's frame is still on its way
    spool.ack(first)
    spool.ack(second)
    declaration = spool.take(0)
    assert isinstance(declaration, MissingItem) and declaration.reason == "camera gone"
    spool.release(declaration)
    spool.end_pass(key)
    assert spool.take(0) == declaration
    assert spool.take(0) is None  # close waits for the acknowledgement
    spool.ack(declaration)
    close = spool.take(0)
    assert close == CloseItem(key)
    spool.ack(close)
    assert spool.wait_drained(0)
    assert list(tmp_path.iterdir()) == []


def test_a_full_buffer_refuses_frames_and_frees_space_on_ack(tmp_path: Path) -> None:
    spool = Spool(tmp_path, limit_bytes=25)
    key = spool.begin_pass(REQUEST)
    assert spool.add_frame(key, "left_inner", 0, "v", 1, b"x" * 10)
    assert spool.add_frame(key, "left_inner", 1, "v", 1, b"y" * 10)
    assert not spool.add_frame(key, "left_inner", 2, "v", 1, b"z" * 10)
    assert spool.used_bytes == 20
    spool.ack(spool.take(0))
    assert spool.add_frame(key, "left_inner", 2, "v", 1, b"z" * 10)


def test_a_restarted_spool_resumes_what_was_not_acknowledged(tmp_path: Path) -> None:
    spool = Spool(tmp_path, limit_bytes=1000)
    key = spool.begin_pass(REQUEST)
    spool.set_pass_id(key, 42)
    for seq in range(3):
        spool.add_frame(key, "right_outer", seq, "v-1", 2, bytes([seq]) * 5)
    spool.add_missing(key, "v-1", 2, "right", "right_inner", "timeout")
    spool.ack(spool.take(0))
    (tmp_path / key / "f-right_outer-000009.png").write_bytes(b"half-written")

    resumed = Spool(tmp_path, limit_bytes=1000)
    assert resumed.pass_id(key) == 42
    assert resumed.request(key) == REQUEST
    assert resumed.waiting() == 3
    assert resumed.used_bytes == 10
    frames = resumed.waiting_frames(key)
    assert [(f.seq, f.vehicle_id, f.axle) for f in frames] == [(1, "v-1", 2), (2, "v-1", 2)]
    assert not (tmp_path / key / "f-right_outer-000009.png").exists()


def test_frames_the_server_already_has_are_acknowledged_without_sending(tmp_path: Path) -> None:
    spool = Spool(tmp_path, limit_bytes=1000)
    key = spool.begin_pass(REQUEST)
    spool.add_frame(key, "left_inner", 0, "v", 1, b"a")
    spool.add_frame(key, "left_inner", 1, "v", 1, b"b")
    first = spool.waiting_frames(key)[0]
    stored = {("left_inner", 0, first.sha256), ("left_inner", 1, "other-sha")}
    assert spool.ack_where(key, stored) == 1
    assert [f.seq for f in spool.waiting_frames(key)] == [1]


def test_the_full_buffer_warning_is_given_once_until_the_buffer_drains(tmp_path: Path) -> None:
    """A frame that still fits after a refusal (frames differ in size; or a camera thread's
    check running after another's refusal) does not re-arm the warning: the parallel test
    run once saw 'local buffer full' twice."""
    spool = Spool(tmp_path / "spool", limit_bytes=100)
    warnings: list[str] = []
    progress = Progress(("left_inner",), 1, spool, warnings.append)
    key = spool.begin_pass(PassOpen("s", "2026-11-23T22:00:00+00:00", None, None, 1, None))
    assert spool.add_frame(key, "left_inner", 0, "v", 1, bytes(90))
    progress.frame_captured("left_inner")  # 90 %: nearly full
    progress.frame_refused("left_inner")  # full
    progress.frame_captured("left_inner")  # a smaller frame fitted: still 90 %
    progress.frame_refused("left_inner")
    assert [w.split(" (")[0] for w in warnings] == [
        "warning: local buffer nearly full",
        "warning: local buffer full: new frames are declared missing",
    ]
    for item in drain_all(spool):
        spool.ack(item)
    progress.frame_captured("left_inner")  # drained: 0 %
    assert spool.add_frame(key, "left_inner", 1, "v", 1, bytes(95))
    progress.frame_refused("left_inner")
    assert len(warnings) == 3 and "full: new frames" in warnings[-1]


def drain_all(spool: Spool) -> list[SpoolItem]:
    items: list[SpoolItem] = []
    while (item := spool.take(timeout_s=0.0)) is not None and not isinstance(item, CloseItem):
        items.append(item)
    return items
