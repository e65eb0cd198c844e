"""The stepped clock's bookkeeping (rfidnav_common.step_ledger): when a step counts as answered."""

from __future__ import annotations

import pytest

from rfidnav_common.step_ledger import OBSERVER_SLACK, StepLedger, StepReport

pytestmark = pytest.mark.tier("unit")

SIM, READER, CONTROLLER, RECORDER = "/robot_sim", "/rfid_reader_sim", "/heading_controller", "/recorder"


def report(node: str, consumed: dict[str, int], produced: dict[str, int] | None = None, incarnation: int = 1,
           slack: int = 0) -> StepReport:
    return StepReport(node, incarnation, consumed, produced or {}, slack)


def started_ledger() -> StepLedger:
    """The simulator, a reader and a controller, all heard from once before anything was published."""
    ledger = StepLedger([SIM, READER, CONTROLLER])
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 0}))
    ledger.report(report(READER, {"/sim/ground_truth": 0}, {"/rfid/reads": 0}))
    ledger.report(report(CONTROLLER, {"/rfid/reads": 0}, {"/cmd_vel": 0}))
    return ledger


def test_a_step_waits_for_participants_never_heard_from() -> None:
    ledger = StepLedger([SIM, READER])
    ledger.report(report(SIM, {}, {}))
    assert not ledger.answered()
    assert [u.describe() for u in ledger.unanswered()] == [f"{READER} (not heard from yet)"]


def test_a_step_is_answered_only_once_the_whole_chain_has_handled_it() -> None:
    ledger = started_ledger()
    assert ledger.answered()
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 1}))          # the step's ground truth
    assert [(u.node, u.topic, u.behind) for u in ledger.unanswered()] == [(READER, "/sim/ground_truth", 1)]
    ledger.report(report(READER, {"/sim/ground_truth": 1}, {"/rfid/reads": 1}))      # it read a round
    assert [(u.node, u.topic) for u in ledger.unanswered()] == [(CONTROLLER, "/rfid/reads")]
    ledger.report(report(CONTROLLER, {"/rfid/reads": 1}, {"/cmd_vel": 1}))           # and commanded
    # The command is counted as sent, but has not reached the simulator yet.
    assert [(u.node, u.topic) for u in ledger.unanswered()] == [(SIM, "/cmd_vel")]
    ledger.report(report(SIM, {"/cmd_vel": 1}, {"/sim/ground_truth": 1}))
    assert ledger.answered() and ledger.unanswered() == []


def test_a_node_that_publishes_nothing_in_answer_completes_the_step_by_its_count_alone() -> None:
    ledger = started_ledger()
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 1}))
    ledger.report(report(READER, {"/sim/ground_truth": 1}, {"/rfid/reads": 0}))     # no round due
    assert ledger.answered()


def test_nodes_that_are_no_participants_are_ignored() -> None:
    ledger = started_ledger()
    assert ledger.report(report("/llrp_reader", {}, {"/rfid/reads": 5})) is False
    assert ledger.answered()


def test_slack_lets_a_recorder_lag_that_many_messages() -> None:
    ledger = StepLedger([SIM, RECORDER])
    ledger.report(report(SIM, {}, {"/odom": 0}))
    ledger.report(report(RECORDER, {"/odom": 0}, slack=2))
    ledger.report(report(SIM, {}, {"/odom": 2}))
    assert ledger.answered()
    ledger.report(report(SIM, {}, {"/odom": 3}))
    assert [(u.node, u.behind) for u in ledger.unanswered()] == [(RECORDER, 3)]


def test_a_restarted_participant_owes_nothing_from_before_and_its_old_messages_stay_counted() -> None:
    ledger = started_ledger()
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 1}))
    ledger.report(report(READER, {"/sim/ground_truth": 1}, {"/rfid/reads": 1}))
    ledger.report(report(CONTROLLER, {"/rfid/reads": 1}, {"/cmd_vel": 1}))
    ledger.report(report(SIM, {"/cmd_vel": 1}, {"/sim/ground_truth": 1}))
    # The controller dies with a round in flight; its new process has handled nothing.
    ledger.report(report(SIM, {"/cmd_vel": 1}, {"/sim/ground_truth": 2}))
    ledger.report(report(READER, {"/sim/ground_truth": 2}, {"/rfid/reads": 2}))
    ledger.report(report(CONTROLLER, {"/rfid/reads": 0}, {"/cmd_vel": 0}, incarnation=2))
    assert ledger.answered()
    # Its first new command is a new debt of the simulator's: the old one is still counted.
    ledger.report(report(CONTROLLER, {"/rfid/reads": 0}, {"/cmd_vel": 1}, incarnation=2))
    assert ledger.published("/cmd_vel") == 2
    assert [(u.node, u.topic) for u in ledger.unanswered()] == [(SIM, "/cmd_vel")]


def test_an_input_first_reported_late_owes_only_what_comes_after() -> None:
    ledger = StepLedger([SIM, READER, RECORDER])
    ledger.report(report(READER, {"/sim/ground_truth": 0}, {"/rfid/reads": 0}))
    ledger.report(report(RECORDER, {}))                               # no subscription yet
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 4}))
    ledger.report(report(READER, {"/sim/ground_truth": 4}, {"/rfid/reads": 0}))
    ledger.report(report(RECORDER, {"/sim/ground_truth": 0}))       # subscribed after four went by
    assert ledger.answered()
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 5}))
    ledger.report(report(READER, {"/sim/ground_truth": 5}, {"/rfid/reads": 0}))
    # It owes the one message after it subscribed (a sink: an observer, which may lag, so look at what it owes)
    assert [(u.node, u.behind) for u in ledger.behind()] == [(RECORDER, 1)]


def test_a_step_waits_until_each_producer_has_matched_every_participant_consuming_its_topic() -> None:
    ledger = StepLedger([SIM, READER, CONTROLLER, RECORDER])
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 0}))
    ledger.report(report(READER, {"/sim/ground_truth": 0}, {"/rfid/reads": 0}))
    ledger.report(report(RECORDER, {"/rfid/reads": 0}))
    # The controller's publisher has found the recorder but not the simulator yet (discovery lags): a command
    # sent now would reach only the recorder, and the simulator would be counted behind on it for ever.
    ledger.report(StepReport(CONTROLLER, 1, {"/rfid/reads": 0}, {"/cmd_vel": 0}, matched={"/cmd_vel": 0}))
    ledger.report(StepReport(READER, 1, {"/sim/ground_truth": 0}, {"/rfid/reads": 0}, matched={"/rfid/reads": 1}))
    assert [u.describe() for u in ledger.unanswered()] == [
        f"{READER}'s /rfid/reads to reach its consumers (1 of 2 matched)",
        f"{CONTROLLER}'s /cmd_vel to reach its consumers (0 of 1 matched)"]
    ledger.report(StepReport(READER, 1, {"/sim/ground_truth": 0}, {"/rfid/reads": 0}, matched={"/rfid/reads": 2}))
    # A foreign listener as well (``rfidnav echo /cmd_vel``) is more than needed, which is fine.
    ledger.report(StepReport(CONTROLLER, 1, {"/rfid/reads": 0}, {"/cmd_vel": 0}, matched={"/cmd_vel": 2}))
    assert ledger.answered()


def test_a_consumer_that_subscribes_late_holds_the_step_until_the_producer_has_matched_it() -> None:
    ledger = StepLedger([SIM, CONTROLLER])
    ledger.report(StepReport(SIM, 1, {}, {"/sim/ground_truth": 0}, matched={"/sim/ground_truth": 0}))
    ledger.report(report(CONTROLLER, {}))
    assert ledger.answered()                                   # nobody consumes ground truth yet
    ledger.report(report(CONTROLLER, {"/sim/ground_truth": 0}))
    assert [(u.node, u.topic) for u in ledger.unanswered()] == [(SIM, "/sim/ground_truth")]
    ledger.report(StepReport(SIM, 1, {}, {"/sim/ground_truth": 0}, matched={"/sim/ground_truth": 1}))
    assert ledger.answered()


def test_a_step_waits_until_each_consumers_subscription_has_matched_every_participant_producing_its_topic() -> None:
    ledger = StepLedger([SIM, CONTROLLER])
    # The controller's publisher has already matched the simulator's subscription, but the simulator's subscription
    # has not matched the controller's publisher yet: DDS would drop a command sent now on the simulator's side.
    ledger.report(StepReport(CONTROLLER, 1, {}, {"/cmd_vel": 0}, matched={"/cmd_vel": 1}))
    ledger.report(StepReport(SIM, 1, {"/cmd_vel": 0}, {}, subscribed={"/cmd_vel": 0}))
    assert [u.describe() for u in ledger.wiring()] == [
        f"{SIM}'s subscription to /cmd_vel to match its producers (0 of 1)"]
    assert not ledger.answered()
    ledger.report(StepReport(SIM, 1, {"/cmd_vel": 0}, {}, subscribed={"/cmd_vel": 1}))
    assert ledger.wiring() == [] and ledger.answered()


def test_wiring_names_the_participants_never_heard_from_first() -> None:
    ledger = StepLedger([SIM, CONTROLLER])
    ledger.report(StepReport(SIM, 1, {"/cmd_vel": 0}, {}, subscribed={"/cmd_vel": 0}))
    assert [u.describe() for u in ledger.wiring()] == [f"{CONTROLLER} (not heard from yet)"]


LOCALIZER = "/rfid_localizer"


def observed_ledger() -> StepLedger:
    """The started ledger with a localizer beside the loop whose pose only the recorder takes."""
    ledger = StepLedger([SIM, READER, CONTROLLER, LOCALIZER, RECORDER])
    ledger.report(report(SIM, {"/cmd_vel": 0}, {"/sim/ground_truth": 0, "/odom": 0}))
    ledger.report(report(READER, {"/sim/ground_truth": 0}, {"/rfid/reads": 0}))
    ledger.report(report(CONTROLLER, {"/rfid/reads": 0}, {"/cmd_vel": 0}))
    ledger.report(report(LOCALIZER, {"/rfid/reads": 0, "/odom": 0}, {"/fused/pose": 0}))
    ledger.report(report(RECORDER, {"/fused/pose": 0, "/odom": 0}, {}, slack=50))
    return ledger


def test_a_participant_whose_outputs_only_the_recorder_takes_is_an_observer_the_loop_does_not_wait_for() -> None:
    ledger = observed_ledger()
    assert ledger.observers == {LOCALIZER}
    for step in range(1, OBSERVER_SLACK + 1):     # the loop runs on; the localizer has handled nothing yet
        ledger.report(report(SIM, {"/cmd_vel": step - 1}, {"/sim/ground_truth": step, "/odom": step}))
        ledger.report(report(READER, {"/sim/ground_truth": step}, {"/rfid/reads": step}))
        ledger.report(report(CONTROLLER, {"/rfid/reads": step}, {"/cmd_vel": step}))
        ledger.report(report(SIM, {"/cmd_vel": step}, {"/sim/ground_truth": step, "/odom": step}))
        assert ledger.answered(), step
        assert not ledger.settled()
    step = OBSERVER_SLACK + 1
    ledger.report(report(SIM, {"/cmd_vel": step - 1}, {"/sim/ground_truth": step, "/odom": step}))
    ledger.report(report(READER, {"/sim/ground_truth": step}, {"/rfid/reads": step}))
    ledger.report(report(CONTROLLER, {"/rfid/reads": step}, {"/cmd_vel": step}))
    ledger.report(report(SIM, {"/cmd_vel": step}, {"/sim/ground_truth": step, "/odom": step}))
    assert [(u.node, u.topic, u.behind) for u in ledger.unanswered()] == \
        [(LOCALIZER, "/rfid/reads", step), (LOCALIZER, "/odom", step)]
    ledger.report(report(LOCALIZER, {"/rfid/reads": step, "/odom": step}, {"/fused/pose": step}))
    assert ledger.answered() and not ledger.settled()     # the recorder is still behind, within its slack
    ledger.report(report(RECORDER, {"/fused/pose": step, "/odom": step}, {}, slack=50))
    assert ledger.settled() and ledger.behind() == []


def test_a_participant_whose_outputs_another_lockstep_participant_takes_is_no_observer() -> None:
    ledger = observed_ledger()
    ledger.report(report("/pose_navigator", {"/fused/pose": 0}, {"/cmd_vel": 0}))   # not a participant: ignored
    assert ledger.observers == {LOCALIZER}
    navigated = StepLedger([SIM, LOCALIZER, "/pose_navigator"])
    navigated.report(report(SIM, {"/cmd_vel": 0}, {"/odom": 0}))
    navigated.report(report(LOCALIZER, {"/odom": 0}, {"/fused/pose": 0}))
    navigated.report(report("/pose_navigator", {"/fused/pose": 0}, {"/cmd_vel": 0}))
    assert navigated.observers == frozenset()
    # A service call's answers are a topic the caller both produces and consumes: it is no observer either.
    calling = StepLedger([SIM, LOCALIZER])
    calling.report(report(SIM, {}, {"/odom": 0}))
    calling.report(report(LOCALIZER, {"/odom": 0, "/locate (answers)": 0}, {"/locate (answers)": 0}))
    assert calling.observers == frozenset()
