"""What a driver says when its host was frozen (SIGSTOP, swapping) in the middle of a motion.

Two checks can see a freeze, and which one does depends on where in the cycle the process was
stopped: the control loop's lateness check, at the top of the cycle ("late, more than the
watchdog bound"), or, when the freeze falls between that check and the send, the driver's
send-by check just before the bytes go out (``odolab.robot.interface.check_send_by``: "past its
send-by time"). Both raise LateCycleError, send stop and fail the run; a test that stops a
driver at a random moment must accept either (a full-suite run on 2026-11-29 met the second on
the 2014 link, with three test processes on two cores). The loop checks twice a cycle: at its
top, where the lateness also goes into the run's record (``stats.lateness_max``), and again
just before the motion command, where a freeze after the top shows in the sentence only (a
full-suite run met that one too, with four test processes on two cores): the sentence says how
late the cycle ran, wherever it was seen."""

from __future__ import annotations

import re

LOOP_LATE = "late, more than the watchdog bound 0.5 s"
SEND_BY = re.compile(r"the motion command was ([0-9.]+) s past its send-by time")
LOOP_RAN = re.compile(r"control cycle \d+ ran ([0-9.]+) s late")


def refused_after_freeze(err: str, freeze: float) -> str:
    """Which check refused to resume after a freeze of ``freeze`` s (``"loop"`` or
    ``"send-by"``); fails the test when neither said so, or the check saw less than the freeze
    (0.1 s allowed for scheduling)."""
    if LOOP_LATE in err:
        m = LOOP_RAN.search(err)
        assert m is not None, err
        assert float(m.group(1)) >= freeze - 0.1, err
        return "loop"
    m = SEND_BY.search(err)
    assert m is not None, err
    assert float(m.group(1)) >= freeze - 0.1, err
    return "send-by"
