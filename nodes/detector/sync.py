"""Pairs images with the camera_info of the *same* stamp, newest first, never backwards.

The sim publishes both with one stamp, but over DDS either may arrive first, one may be
lost (best-effort sensor QoS), or a publisher may send camera_info with another stamp. A
``StampPairer`` holds a few unpaired messages of each kind and hands out a pair as soon as
both halves are there. Once a frame is handed out, anything at or before its stamp is
stale: it is dropped and reported, so a pose is never published from an image older than
one already processed.

One exception: a stamp more than ``jump_back_ns`` older than the last frame means the clock
itself went back (the simulator was reset and restarted its time), not a late frame; the
pairer then starts afresh and says so (``PairResult.clock_reset``).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any


@dataclass
class PairResult:
    """A ready (stamp_ns, image, info) triple, if any, and (stamp_ns, reason) of drops."""

    pair: tuple[int, Any, Any] | None = None
    dropped: list[tuple[int, str]] = field(default_factory=list)
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
            result.dropped.append((stamp_ns, f"image not newer than the last frame "
                                              f"processed ({self.last_ns} ns)"))
            return result
        if stamp_ns in self.infos:
            return self._emit(stamp_ns, image, self.infos.pop(stamp_ns), result)
        self.images[stamp_ns] = image
        self._bound(self.images, result, "no camera_info with this stamp arrived")
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
            result.dropped.append((stamp, "no camera_info with this stamp arrived before a "
                                          "newer frame was complete"))
        for stamp in [s for s in self.infos if s <= stamp_ns]:
            del self.infos[stamp]
        result.pair = (stamp_ns, image, info)
        return result

    def _bound(self, buffer: OrderedDict[int, Any], result: PairResult,
               reason: str | None) -> None:
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
