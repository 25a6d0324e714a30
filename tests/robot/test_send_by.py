"""A freeze between the loop's lateness check and the send never sends the stale command
(issue 39, item 5: in 1 of 13 SIGSTOP trials the old motion command went out once after
SIGCONT, 6 ms before the stop). The driver checks the send-by time with its clock read just
before the bytes go to the transport, on both links; here the freeze is a jump of the simulated
clock while the command is being encoded, the last step before the old code sent it."""

from __future__ import annotations

from typing import Any

import pytest

from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS
from odolab.robot.clock import SimClock
from odolab.robot.config import RunConfig
from odolab.robot.errors import LateCycleError
from odolab.robot.interface import check_send_by
from odolab.robot.loop import ControlLoop
from odolab.robot.motions import Straight
from odolab.robot.plant import IdealPlant
from odolab.robot.registry import open_in_process

NOMINAL = PRESETS["jaguar-lite"]
#: (link, the module whose encoder of motion commands the freeze lands in, its name)
LINKS = [
    ("jaguar", "odolab.robot.jaguar.driver", "encode_motor_command"),
    ("jaguar2014", "odolab.robot.jaguar2014.driver", "encode_drive"),
]


@pytest.mark.parametrize(("link", "module", "encoder"), LINKS)
def test_a_freeze_after_the_check_sends_stop_not_the_stale_command(
    link: str, module: str, encoder: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import importlib

    clock = SimClock()
    opened = open_in_process(link, RunConfig(), NOMINAL, clock, IdealPlant(NOMINAL))
    driver: Any = opened.driver
    sent: list[tuple[float, bytes]] = []
    real_send = driver.transport.send

    def send(data: bytes) -> None:
        sent.append((clock.now(), bytes(data)))
        real_send(data)

    monkeypatch.setattr(driver.transport, "send", send)
    mod = importlib.import_module(module)
    real_encode = getattr(mod, encoder)
    calls = {"n": 0, "frozen_at": -1.0}

    def encode(*args: Any) -> Any:
        calls["n"] += 1
        if calls["n"] == 15:  # SIGSTOP lands here, SIGCONT 1 s later
            calls["frozen_at"] = clock.now()
            clock.advance(1.0)
        return real_encode(*args)

    monkeypatch.setattr(mod, encoder, encode)
    loop = ControlLoop(driver, Odometry(NOMINAL), clock, rate=20.0)
    with pytest.raises(LateCycleError, match="past its send-by time when it was about to go out"):
        loop.run(Straight(2.0, speed=0.5))
    frozen = calls["frozen_at"]
    assert frozen > 0
    after = [data for t, data in sent if t > frozen]
    stop = driver._stop_packet if link == "jaguar" else importlib.import_module(module).STOP
    # the stale command never went out: only stops after the freeze, the first at once
    assert after and all(data == stop for data in after), after
    assert loop.partial is not None and not loop.partial.completed


def test_check_send_by_holds_only_past_the_time() -> None:
    check_send_by(1.0, None)
    check_send_by(1.0, 1.0)
    with pytest.raises(LateCycleError, match=r"^the motion command was 0.250 s past"):
        check_send_by(1.25, 1.0)
