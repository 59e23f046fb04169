"""Axle counting: labels follow the trigger sequence, vehicle ids from tags or numbered."""

from __future__ import annotations

import queue
import socket
import threading
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from backend.agent.axles import (
    AxleCounter,
    AxleEvent,
    EndEvent,
    EventError,
    VehicleTag,
    parse_tag,
    parse_wheel_event,
    start_reader,
)
from tests.backend.agent.live_server import free_port


def label_train(counter: AxleCounter, axles: int, tags: list[VehicleTag]) -> list[tuple]:
    pending = list(tags)
    labels = [counter.count_axle(lambda: pending.pop(0) if pending else None) for _ in range(axles)]
    return [(x.index, x.vehicle_id, x.axle) for x in labels]


def test_untagged_vehicles_are_numbered_in_order() -> None:
    labels = label_train(AxleCounter(axles_per_vehicle=2), 5, [])
    assert labels == [(0, "1", 1), (1, "1", 2), (2, "2", 1), (3, "2", 2), (4, "3", 1)]


def test_tags_name_vehicles_and_their_axle_counts() -> None:
    tags = [VehicleTag("loco", 6), VehicleTag("wagon-1")]
    labels = label_train(AxleCounter(axles_per_vehicle=4), 12, tags)
    assert [v for _, v, _ in labels] == ["loco"] * 6 + ["wagon-1"] * 4 + ["3"] * 2
    assert [a for _, _, a in labels] == [1, 2, 3, 4, 5, 6, 1, 2, 3, 4, 1, 2]


@given(st.lists(st.integers(1, 8), min_size=1, max_size=6))
def test_labels_reproduce_any_consist(axle_counts: list[int]) -> None:
    tags = [VehicleTag(f"v{n}", count) for n, count in enumerate(axle_counts)]
    labels = label_train(AxleCounter(axles_per_vehicle=4), sum(axle_counts), tags)
    expected = [(f"v{n}", a) for n, count in enumerate(axle_counts) for a in range(1, count + 1)]
    assert [(v, a) for _, v, a in labels] == expected
    assert [i for i, _, _ in labels] == list(range(sum(axle_counts)))


def test_event_lines_parse() -> None:
    assert parse_wheel_event('{"event": "axle", "speed_kmh": 12.5}') == AxleEvent(12.5)
    assert parse_wheel_event('{"event": "end"}') == EndEvent()
    assert parse_tag('{"vehicle_id": "80-91", "axles": 4}') == VehicleTag("80-91", 4)


@pytest.mark.parametrize(
    ("parse", "line", "message"),
    [
        (parse_wheel_event, "axle", r"wheel-sensor line is not JSON"),
        (parse_wheel_event, '{"event": "wheel"}', r"must be 'axle' or 'end', got 'wheel'"),
        (parse_wheel_event, '{"event": "axle", "speed_kmh": "fast"}', r"speed_kmh must be"),
        (parse_tag, "[1]", r"tag-reader line must be a JSON object"),
        (parse_tag, '{"vehicle_id": ""}', r"vehicle_id must be a non-empty string"),
        (parse_tag, '{"vehicle_id": "a", "axles": 0}', r"axles must be an integer ≥ 1"),
    ],
)
def test_bad_event_lines_are_named(parse, line: str, message: str) -> None:
    with pytest.raises(EventError, match=message):
        parse(line)


def test_a_tcp_wheel_sensor_feeds_events_from_each_connection_in_turn() -> None:
    port = free_port()
    stop = threading.Event()
    events: queue.Queue[object] = queue.Queue()
    start_reader(f"tcp://127.0.0.1:{port}", parse_wheel_event, events, stop)
    try:
        for lines in (b'{"event": "axle", "speed_kmh": 30}\n', b'\n{"event": "end"}\n'):
            deadline = time.monotonic() + 30
            while True:
                try:
                    connection = socket.create_connection(("127.0.0.1", port), timeout=5)
                    break
                except ConnectionRefusedError:
                    assert time.monotonic() < deadline
                    time.sleep(0.02)
            with connection:
                connection.sendall(lines)
        assert events.get(timeout=30) == AxleEvent(30.0)
        assert events.get(timeout=30) == EndEvent()
    finally:
        stop.set()
    assert events.get(timeout=30) is None


def test_a_bad_line_is_reported_and_reading_goes_on(tmp_path) -> None:
    path = tmp_path / "axles.jsonl"
    path.write_text('{"event": "axle"}\n{"event": "brake"}\n{"event": "axle"}\n')
    events: queue.Queue[object] = queue.Queue()
    start_reader(f"file:{path}", parse_wheel_event, events, threading.Event())
    assert events.get(timeout=30) == AxleEvent()
    error = events.get(timeout=30)
    assert isinstance(error, EventError) and "got 'brake'" in str(error)
    assert events.get(timeout=30) == AxleEvent()
    assert events.get(timeout=30) is None
