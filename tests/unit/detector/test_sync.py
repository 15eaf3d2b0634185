"""Exact-stamp pairing of images and camera_info, never going back in time, and the newest
complete frame handed to the worker with every older one counted as dropped."""

from __future__ import annotations

import threading

from nodes.detector.sync import Drop, FrameInbox, StampPairer


def test_pairs_whichever_half_comes_first():
    p = StampPairer()
    assert p.add_image(10, "img10").pair is None
    assert p.add_info(10, "info10").pair == (10, "img10", "info10")
    assert p.add_info(20, "info20").pair is None
    assert p.add_image(20, "img20").pair == (20, "img20", "info20")


def test_mismatched_stamps_never_pair():
    p = StampPairer()
    p.add_image(10, "img")
    assert p.add_info(11, "info").pair is None


def test_an_image_older_than_the_last_frame_is_dropped():
    p = StampPairer()
    p.add_info(20, "i20")
    p.add_image(20, "m20")
    p.add_info(10, "i10")
    result = p.add_image(10, "m10")
    assert result.pair is None and result.dropped == [(10, Drop.STALE)]


def test_a_newer_frame_flushes_unpaired_older_images():
    p = StampPairer()
    p.add_image(10, "m10")  # its camera_info is lost
    p.add_image(20, "m20")
    result = p.add_info(20, "i20")
    assert result.pair[0] == 20
    assert result.dropped == [(10, Drop.INCOMPLETE)]
    assert p.add_info(10, "i10").pair is None  # late info for a skipped frame: ignored


def test_images_without_camera_info_do_not_pile_up():
    p = StampPairer(max_pending=3)
    dropped = []
    for stamp in range(10):
        dropped += p.add_image(stamp, stamp).dropped
    assert len(p.images) == 3 and dropped == [(s, Drop.UNPAIRED) for s in range(7)]


def test_a_clock_reset_starts_afresh():
    p = StampPairer(jump_back_ns=1_000)
    p.add_image(50_000, "a")
    p.add_info(50_000, "a")
    result = p.add_image(100, "b")
    assert result.clock_reset and result.pair is None
    assert p.add_info(100, "b").pair == (100, "b", "b")


def send(inbox: FrameInbox, stamp: int) -> None:
    inbox.add_info(stamp, f"i{stamp}")
    inbox.add_image(stamp, f"m{stamp}")


def test_the_worker_gets_the_newest_complete_frame_and_older_ones_are_counted():
    """A stream faster than the worker: frames completed while one waits replace it."""
    inbox = FrameInbox()
    send(inbox, 10)
    assert inbox.take(0.0) == (10, "m10", "i10")
    for stamp in (20, 30, 40):  # the worker is busy with frame 10 meanwhile
        send(inbox, stamp)
    inbox.add_image(50, "m50")  # its camera_info has not come yet
    assert inbox.take(0.0) == (40, "m40", "i40")
    assert inbox.take(0.0) is None  # nothing newer complete: nothing to do
    counts, received = inbox.snapshot()
    assert counts == {Drop.SUPERSEDED: 2} and received == 5
    inbox.add_image(60, "m60")
    inbox.add_info(60, "i60")  # 60 completes first: 50 never will
    assert inbox.take(0.0)[0] == 60
    assert inbox.snapshot()[0] == {Drop.SUPERSEDED: 2, Drop.INCOMPLETE: 1}
    inbox.add_image(55, "m55")  # late: older than a frame handed on
    assert inbox.take(0.0) is None and inbox.counts[Drop.STALE] == 1


def test_take_waits_for_a_frame_and_close_wakes_it():
    inbox = FrameInbox()
    got = []
    worker = threading.Thread(target=lambda: got.append(inbox.take(10.0)))
    worker.start()
    send(inbox, 7)
    worker.join(5.0)
    assert got == [(7, "m7", "i7")]
    worker = threading.Thread(target=lambda: got.append(inbox.take(10.0)))
    worker.start()
    inbox.close()
    worker.join(5.0)
    assert not worker.is_alive() and got[-1] is None


def test_a_clock_reset_forgets_the_waiting_frame():
    inbox = FrameInbox(StampPairer(jump_back_ns=1_000))
    send(inbox, 50_000)
    assert inbox.add_image(100, "b").clock_reset
    assert inbox.take(0.0) is None
    inbox.add_info(100, "i")
    assert inbox.take(0.0) == (100, "b", "i")
