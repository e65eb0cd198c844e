"""A stepped participant's record of one publisher's publication sequence numbers (rfidnav_common.in_order): what
a lost DDS match left out is taken from resends, exactly once, and handled in the order it was published."""

from __future__ import annotations

import pytest

from rfidnav_common.in_order import WIDEST_HOLE, InOrder

pytestmark = pytest.mark.tier("unit")


def test_messages_in_order_are_handled_as_they_come() -> None:
    order = InOrder()
    assert [order.arrived(n, f"m{n}") for n in (7, 8, 9)] == [["m7"], ["m8"], ["m9"]]   # the first may be any
    assert not order.lacks()


def test_messages_after_a_hole_wait_for_it_and_are_then_handled_in_the_order_published() -> None:
    order = InOrder()
    order.arrived(1, "m1")
    assert order.arrived(4, "m4") == [] and order.arrived(5, "m5") == [] and order.lacks()
    assert order.resent(3, "m3", lost_since=False) == []           # in a hole: lost for certain, flag or not
    assert order.resent(2, "m2", lost_since=False) == ["m2", "m3", "m4", "m5"]
    assert not order.lacks()
    assert order.arrived(6, "m6") == ["m6"]


def test_a_message_sent_again_that_was_had_is_not_handled_twice() -> None:
    order = InOrder()
    order.arrived(1, "m1")
    order.arrived(3, "m3")
    assert order.resent(1, "m1", lost_since=True) == []
    assert order.resent(2, "m2", lost_since=True) == ["m2", "m3"]
    # the same request answered twice (a request crossing the consumer's answer)
    assert order.resent(2, "m2", lost_since=True) == [] and order.resent(3, "m3", lost_since=True) == []


def test_messages_after_the_newest_are_taken_again_only_when_the_match_was_lost() -> None:
    order = InOrder()
    order.arrived(1, "m1")
    # A consumer merely slow: the original is still coming.
    assert order.resent(2, "m2", lost_since=False) == []
    assert order.arrived(2, "m2") == ["m2"]
    # Lost with the match: taken from the resend; should the original come all the same, it is a duplicate.
    assert order.resent(3, "m3", lost_since=True) == ["m3"]
    assert order.arrived(3, "m3") == []
    assert order.arrived(4, "m4") == ["m4"]


def test_the_very_first_messages_can_be_taken_again_when_the_match_was_lost() -> None:
    order = InOrder()
    assert [order.resent(n, f"m{n}", lost_since=True) for n in (1, 2)] == [["m1"], ["m2"]]
    assert order.arrived(3, "m3") == ["m3"]


def test_a_restarted_publisher_numbering_from_one_again_is_followed_afresh() -> None:
    order = InOrder()
    for n in (1, 2, 3):
        order.arrived(n, f"old{n}")
    order.arrived(5, "old5")           # held behind the hole at 4, which the dead publisher will never fill
    assert order.arrived(1, "new1") == ["old5", "new1"] and not order.lacks()
    assert order.arrived(2, "new2") == ["new2"]


def test_a_hole_wider_than_a_producer_keeps_is_not_waited_for() -> None:
    order = InOrder()
    order.arrived(1, "m1")
    far = 2 + WIDEST_HOLE + 1
    assert order.arrived(far, "far") == ["far"] and not order.lacks()
    assert order.arrived(far + 1, "next") == ["next"]
