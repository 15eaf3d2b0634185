"""Images and camera_info paired by identical stamp, and the newest complete frame handed on.

The sim publishes both with one stamp, but over DDS either may arrive first, one may be
lost (best-effort sensor QoS), or a publisher may send camera_info with another stamp. A
``StampPairer`` holds a few unpaired messages of each kind and hands out a pair as soon as
both halves are there. Once a frame is handed out, anything at or before its stamp is
stale: it is dropped and reported, so a pose is never published from an image older than
one already processed.

One exception: a stamp more than ``jump_back_ns`` older than the last frame means the clock
itself went back (the simulator was reset and restarted its time), not a late frame; the
pairer then starts afresh and says so (``PairResult.clock_reset``).

A camera streams (15-30 Hz for a real driver) faster than the detector may process, so the
``FrameInbox`` between the camera callbacks and the detector's worker holds one complete
frame only, the newest: a frame completed while another waits replaces it
(``Drop.SUPERSEDED``). Every drop is counted by kind; the node logs the counts, not a
warning per frame.
"""

from __future__ import annotations

import enum
import threading
from collections import Counter, OrderedDict
from dataclasses import dataclass, field
from typing import Any


class Drop(enum.Enum):
    """Why a message never became a processed frame."""

    STALE = "image not newer than the last frame handed on"
    INCOMPLETE = "no camera_info with this stamp arrived before a newer frame was complete"
    UNPAIRED = "no camera_info with this stamp arrived (too many images waiting for one)"
    SUPERSEDED = "a newer frame was complete before this one was processed"


Frame = tuple[int, Any, Any]  #: (stamp_ns, image, camera_info)


@dataclass
class PairResult:
    """A ready (stamp_ns, image, info) triple, if any, and (stamp_ns, why) of drops."""

    pair: Frame | None = None
    dropped: list[tuple[int, Drop]] = field(default_factory=list)
    clock_reset: bool = False


class StampPairer:
    """Exact-stamp pairing of two streams with bounded buffers."""

    def __init__(self, max_pending: int = 4, jump_back_ns: int = 1_000_000_000) -> None:
        self.max_pending = max_pending
        self.jump_back_ns = jump_back_ns
        self.images: OrderedDict[int, Any] = OrderedDict()
        self.infos: OrderedDict[int, Any] = OrderedDict()
        self.last_ns: int | None = None  # stamp of the newest frame handed out

    def _stale(self, stamp_ns: int) -> bool:
        return self.last_ns is not None and stamp_ns <= self.last_ns

    def add_image(self, stamp_ns: int, image: Any) -> PairResult:
        result = self._check_jump(stamp_ns)
        if self._stale(stamp_ns):
            result.dropped.append((stamp_ns, Drop.STALE))
            return result
        if stamp_ns in self.infos:
            return self._emit(stamp_ns, image, self.infos.pop(stamp_ns), result)
        self.images[stamp_ns] = image
        self._bound(self.images, result, Drop.UNPAIRED)
        return result

    def add_info(self, stamp_ns: int, info: Any) -> PairResult:
        result = self._check_jump(stamp_ns)
        if self._stale(stamp_ns):
            return result  # camera_info for a frame already handled (or skipped): harmless
        if stamp_ns in self.images:
            return self._emit(stamp_ns, self.images.pop(stamp_ns), info, result)
        self.infos[stamp_ns] = info
        self._bound(self.infos, result, None)
        return result

    def _check_jump(self, stamp_ns: int) -> PairResult:
        if self.last_ns is not None and self.last_ns - stamp_ns > self.jump_back_ns:
            self.reset()
            return PairResult(clock_reset=True)
        return PairResult()

    def _emit(self, stamp_ns: int, image: Any, info: Any, result: PairResult) -> PairResult:
        self.last_ns = stamp_ns
        for stamp in [s for s in self.images if s <= stamp_ns]:
            del self.images[stamp]
            result.dropped.append((stamp, Drop.INCOMPLETE))
        for stamp in [s for s in self.infos if s <= stamp_ns]:
            del self.infos[stamp]
        result.pair = (stamp_ns, image, info)
        return result

    def _bound(self, buffer: OrderedDict[int, Any], result: PairResult,
               reason: Drop | None) -> None:
        while len(buffer) > self.max_pending:
            oldest = min(buffer)
            del buffer[oldest]
            if reason is not None:
                result.dropped.append((oldest, reason))

    def reset(self) -> None:
        """Forget pending halves and the last stamp (e.g. simulated time jumped back)."""
        self.images.clear()
        self.infos.clear()
        self.last_ns = None


class FrameInbox:
    """Thread-safe hand-over from the camera callbacks to one worker: the callbacks add
    halves (``add_image``, ``add_info``), the worker ``take``s the newest complete frame.

    ``counts`` holds, per ``Drop``, how many messages were dropped, and ``received`` the
    images seen (each is taken, dropped or still waiting for its camera_info).
    """

    def __init__(self, pairer: StampPairer | None = None) -> None:
        self.pairer = pairer or StampPairer()
        self._ready = threading.Condition()
        self._latest: Frame | None = None
        self._closed = False
        self.counts: Counter[Drop] = Counter()
        self.received = 0

    def add_image(self, stamp_ns: int, image: Any) -> PairResult:
        with self._ready:
            self.received += 1
            return self._offer(self.pairer.add_image(stamp_ns, image))

    def add_info(self, stamp_ns: int, info: Any) -> PairResult:
        with self._ready:
            return self._offer(self.pairer.add_info(stamp_ns, info))

    def _offer(self, result: PairResult) -> PairResult:
        if result.clock_reset:
            self._latest = None
        if result.pair is not None:
            if self._latest is not None:
                result.dropped.append((self._latest[0], Drop.SUPERSEDED))
            self._latest = result.pair
            self._ready.notify_all()
        self.counts.update(why for _, why in result.dropped)
        return result

    def take(self, timeout: float | None = None) -> Frame | None:
        """The newest complete frame not taken yet, waiting up to ``timeout`` s for one;
        None if none came (or the inbox was closed)."""
        with self._ready:
            self._ready.wait_for(lambda: self._latest is not None or self._closed, timeout)
            frame, self._latest = self._latest, None
            return frame

    def snapshot(self) -> tuple[Counter[Drop], int]:
        """(drops by why, images received) so far, read consistently."""
        with self._ready:
            return Counter(self.counts), self.received

    def reset(self) -> None:
        """Forget everything pending (the clock jumped back)."""
        with self._ready:
            self.pairer.reset()
            self._latest = None

    def close(self) -> None:
        """Wake the worker for good (the node shuts down)."""
        with self._ready:
            self._closed = True
            self._ready.notify_all()
