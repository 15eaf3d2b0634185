"""Exact-stamp pairing of images and camera_info, never going back in time."""

from __future__ import annotations

from nodes.detector.sync import StampPairer


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
    assert result.pair is None and result.dropped and result.dropped[0][0] == 10


def test_a_newer_frame_flushes_unpaired_older_images():
    p = StampPairer()
    p.add_image(10, "m10")  # its camera_info is lost
    p.add_image(20, "m20")
    result = p.add_info(20, "i20")
    assert result.pair[0] == 20
    assert [s for s, _ in result.dropped] == [10]
    assert p.add_info(10, "i10").pair is None  # late info for a skipped frame: ignored


def test_images_without_camera_info_do_not_pile_up():
    p = StampPairer(max_pending=3)
    dropped = []
    for stamp in range(10):
        dropped += p.add_image(stamp, stamp).dropped
    assert len(p.images) == 3 and [s for s, _ in dropped] == list(range(7))


def test_a_clock_reset_starts_afresh():
    p = StampPairer(jump_back_ns=1_000)
    p.add_image(50_000, "a")
    p.add_info(50_000, "a")
    result = p.add_image(100, "b")
    assert result.clock_reset and result.pair is None
    assert p.add_info(100, "b").pair == (100, "b", "b")
