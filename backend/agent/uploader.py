"""Drains the spool to the server: opens passes, PUTs frames, declares missing, closes.

Workers (threads, one HTTP connection each) take items from the spool in capture order. A
send that fails because the server is away puts the item back and the worker waits with
back-off; when the server answers again, each pass is re-synchronised first (GET .../frames)
so frames that arrived before the connection dropped are not sent twice. A PUT is idempotent
anyway (200 for the identical frame). A refused token stops the agent; a request the server
rejects for good (bad image, conflicting frame) is dropped with a warning, never retried.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from backend.agent.client import (
    PutResult,
    RequestRejected,
    ServerUnavailable,
    StreamClient,
    TokenRefused,
)
from backend.agent.progress import Progress
from backend.agent.spool import CloseItem, FrameItem, MissingItem, PassOpen, Spool, SpoolItem

BACKOFF_MIN_S = 0.2
BACKOFF_MAX_S = 5.0


class Uploader:
    """Background workers sending the spool's items to the server.

    Parameters
    ----------
    spool : Spool
    make_client : callable returning StreamClient
        One client per worker.
    workers : int
        Concurrent requests.
    progress : Progress
    """

    def __init__(
        self,
        spool: Spool,
        make_client: Callable[[], StreamClient],
        workers: int,
        progress: Progress,
    ) -> None:
        self._spool = spool
        self._make_client = make_client
        self._progress = progress
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._open_locks: dict[str, threading.Lock] = {}
        self._ambiguous_open: set[str] = set()
        self._outages = 0
        self._synced: dict[str, int] = {}
        self._backoff_s = BACKOFF_MIN_S
        self.fatal: BaseException | None = None
        self._threads = [
            threading.Thread(target=self._work, name=f"upload-{n}", daemon=True)
            for n in range(workers)
        ]

    def start(self) -> None:
        """Start the workers."""
        for thread in self._threads:
            thread.start()

    def stop(self) -> None:
        """Stop the workers after their current request (the spool keeps the rest)."""
        self._stop.set()
        for thread in self._threads:
            thread.join()

    @property
    def stopped(self) -> bool:
        """True once stopped or stopped by a fatal error."""
        return self._stop.is_set()

    def _work(self) -> None:
        client = self._make_client()
        try:
            while not self._stop.is_set():
                item = self._spool.take(timeout_s=0.2)
                if item is None:
                    continue
                try:
                    self._handle(client, item)
                except Exception as exc:  # a bug or a disk error: stop loudly, never hang
                    self._spool.release(item)
                    self._fail(RuntimeError(f"uploader failed on {_describe(item)}: {exc!r}"))
        finally:
            client.close()

    def _handle(self, client: StreamClient, item: SpoolItem) -> None:
        result: PutResult | None = None
        try:
            result = self._send(client, item)
        except ServerUnavailable as exc:
            self._spool.release(item)
            self._went_offline(str(exc))
            return
        except TokenRefused as exc:
            self._spool.release(item)
            self._fail(exc)
            return
        except RequestRejected as exc:
            if isinstance(item, CloseItem) or self._spool.pass_id(item.key) is None:
                self._spool.release(item)
                self._fail(ValueError(f"server refused the pass: {exc}"))
                return
            if not _settled(self._spool, item, exc):
                self._progress.warn(f"server rejected {_describe(item)} for good: {exc}")
        self._spool.ack(item)
        self._progress.acknowledged(item, result)
        self._came_online()

    def _send(self, client: StreamClient, item: SpoolItem) -> PutResult | None:
        pass_id = self._ensure_open(client, item.key)
        self._resync(client, item.key, pass_id)
        if isinstance(item, FrameItem):
            return client.put_frame(pass_id, item, item.path.read_bytes())
        if isinstance(item, MissingItem):
            client.declare_missing(pass_id, item)
        else:
            client.close_pass(pass_id)
        return None

    def _ensure_open(self, client: StreamClient, key: str) -> int:
        with self._lock:
            lock = self._open_locks.setdefault(key, threading.Lock())
        with lock:
            pass_id = self._spool.pass_id(key)
            if pass_id is not None:
                return pass_id
            request = self._spool.request(key)
            if key in self._ambiguous_open:
                pass_id = _find_quietly(client, request)
            if pass_id is None:
                try:
                    pass_id = client.open_pass(request)
                except ServerUnavailable as exc:
                    if exc.delivered:
                        self._ambiguous_open.add(key)
                    raise
            self._spool.set_pass_id(key, pass_id)
            with self._lock:
                self._synced[key] = self._outages
            self._progress.opened(key, pass_id)
            return pass_id

    def _resync(self, client: StreamClient, key: str, pass_id: int) -> None:
        with self._lock:
            if self._synced.get(key, -1) >= self._outages:
                return
            outages = self._outages
        skipped = self._spool.ack_where(key, client.stored_frames(pass_id))
        if skipped:
            self._progress.warn(f"pass {pass_id}: server already had {skipped} frames, not resent")
        with self._lock:
            self._synced[key] = outages

    def _went_offline(self, message: str) -> None:
        with self._lock:
            if self._progress.online:
                self._outages += 1
            backoff = self._backoff_s
            self._backoff_s = min(BACKOFF_MAX_S, self._backoff_s * 2)
        self._progress.set_offline(message)
        self._stop.wait(backoff)

    def _came_online(self) -> None:
        with self._lock:
            self._backoff_s = BACKOFF_MIN_S
        self._progress.set_online()

    def _fail(self, exc: BaseException) -> None:
        with self._lock:
            if self.fatal is None:
                self.fatal = exc
        self._stop.set()


def _find_quietly(client: StreamClient, request: PassOpen) -> int | None:
    try:
        return client.find_pass(request)
    except RequestRejected:
        return None


def _settled(spool: Spool, item: SpoolItem, exc: RequestRejected) -> bool:
    """A 409 that only says the wheel is already settled: "not measured" after a missing
    declaration (a frame arriving after it, or a declaration sent twice)."""
    if exc.status != 409:
        return False
    return isinstance(item, MissingItem) or (
        isinstance(item, FrameItem) and spool.is_declared(item)
    )


def _describe(item: SpoolItem) -> str:
    if isinstance(item, FrameItem):
        return f"frame {item.sensor}/{item.seq} (vehicle {item.vehicle_id} axle {item.axle})"
    if isinstance(item, MissingItem):
        return f"missing declaration {item.sensor} (vehicle {item.vehicle_id} axle {item.axle})"
    return f"close of pass {item.key}"
