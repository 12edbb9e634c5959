"""The machine-stall probe that ``hapticfx bench output`` sets beside the stream's underflows."""

import os
import signal
import sys
import time

from hapticfx_soundcard.bench import stallprobe
from hapticfx_soundcard.bench.output import Capture, Rounds
from hapticfx_soundcard.bench.stallprobe import Stall, StallProbe


def test_a_probe_that_is_not_run_reports_the_stall_on_its_cpu():
    """Stopping a probe process (SIGSTOP) is what a host taking its CPU away looks like from inside."""
    with StallProbe() as probe:
        proc = probe._procs[0]
        time.sleep(0.05)
        stopped = time.monotonic()
        os.kill(proc.pid, signal.SIGSTOP)
        time.sleep(0.08)
        os.kill(proc.pid, signal.SIGCONT)
        time.sleep(0.05)
    cpu = sorted(os.sched_getaffinity(0))[0]
    # the sleep it was in began by the stop (5 ms allowed for scheduling) and ended after the 80 ms
    spanning = [s for s in probe.stalls if s.cpu == cpu and s.start <= stopped + 0.005 and s.end >= stopped + 0.075]
    assert len(spanning) == 1, probe.stalls
    assert probe.started <= spanning[0].start < spanning[0].end <= probe.started + probe.seconds
    assert probe.policy in ("fifo", "other")


def test_every_reported_stall_is_longer_than_the_threshold():
    with StallProbe(period_s=0.001, threshold_s=0.0005) as probe:
        time.sleep(0.3)
    assert 0.25 < probe.seconds < 5
    assert all(s.seconds > 0.0015 for s in probe.stalls)
    assert {s.cpu for s in probe.stalls} <= set(os.sched_getaffinity(0))
    assert all(s >= 0 for s in probe.steal_s.values())
    assert set(probe.steal_s) <= os.sched_getaffinity(0)  # only the CPUs probed


def test_an_underflow_is_put_down_to_a_long_enough_stall_just_before_it():
    probe = StallProbe()
    probe.stalls = [Stall(0, 10.0, 0.012), Stall(1, 20.0, 0.003), Stall(1, 30.0, 0.004), Stall(0, 30.001, 0.011)]
    rounds = Rounds(Capture(48000.0), [10.02, 20.01, 30.05, 40.0, 9.0], probe)
    found = rounds.put_down_to_machine(within_s=0.1, at_least_s=0.005)
    assert found == [probe.stalls[0], None, probe.stalls[3], None, None]


def test_an_underflow_is_matched_to_the_longest_late_callback_just_before_it():
    rounds = Rounds(Capture(48000.0), [10.0, 20.0, 30.0], StallProbe(),
                    late_callbacks=[(9.998, 0.012), (9.9985, 0.020), (19.9, 0.015), (30.001, 0.03)])
    assert [rounds.gap_before(t) for t in rounds.underflow_times] == [0.020, None, None]


def test_a_stall_is_everywhere_when_every_other_cpu_stalled_during_it():
    probe = StallProbe()
    probe.stalls = [Stall(0, 10.0, 0.012), Stall(1, 10.005, 0.010),  # overlapping: the machine paused
                    Stall(0, 20.0, 0.012), Stall(1, 20.013, 0.010),  # one after the other
                    Stall(1, 30.0, 0.008)]                           # one CPU only
    assert [probe.everywhere(s) for s in probe.stalls] == [True, True, False, False, False]
    probe._cpus = [0, 1, 2]  # a third CPU that never stalled
    assert not probe.everywhere(probe.stalls[0])


def test_a_probe_leaves_real_time_priority_before_it_reports(monkeypatch):
    """Reporting and exiting at the highest real-time priority kept the audio being timed off the CPUs
    (an underflow at 5 of 6 exits). The scheduler calls are recorded, not made: this test process must
    not pin itself to one CPU or take real-time priority."""
    events = []

    class Out:
        def write(self, text):
            events.append(("out", text))

        def flush(self):
            pass

    monkeypatch.setattr(os, "sched_setaffinity", lambda pid, cpus: None)
    monkeypatch.setattr(os, "sched_setscheduler", lambda pid, policy, param: events.append(("policy", policy)))
    read, write = os.pipe()
    os.close(write)  # stdin at its end: the probe stops at once, as when the bench closes it
    with os.fdopen(read) as stdin:
        monkeypatch.setattr(sys, "stdin", stdin)
        monkeypatch.setattr(sys, "stdout", Out())
        stallprobe._run(0, 0.001, 0.002)
    policies = [e[1] for e in events if e[0] == "policy"]
    assert policies == [os.SCHED_FIFO, os.SCHED_OTHER]
    report = next(i for i, e in enumerate(events) if e[0] == "out" and e[1].startswith("{"))
    assert events.index(("policy", os.SCHED_OTHER)) < report
