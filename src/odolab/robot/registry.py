"""Robot links by the scheme of the ``--robot`` URL (an explicit registry, no discovery).

=========================  ==========================================================
``udp://HOST:PORT``        a Jaguar board over UDP (:mod:`odolab.robot.jaguar`)
``sim://`` (the default)   a virtual Jaguar board started on 127.0.0.1 for the run
=========================  ==========================================================

A new kind of robot is one package that implements :class:`odolab.robot.interface.Driver` and
an opener, plus one line in :data:`LINKS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from urllib.parse import urlparse

from odolab.params import RobotParams
from odolab.robot.clock import Clock
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotUrlError
from odolab.robot.interface import Driver
from odolab.robot.plant import PlantFactory
from odolab.trajectory import Pose

__all__ = ["DEFAULT_ROBOT_URL", "LINKS", "LinkOpener", "RobotLink", "VirtualSpec", "open_link"]

DEFAULT_ROBOT_URL = "sim://"


@dataclass(frozen=True)
class VirtualSpec:
    """What a virtual robot needs from outside: its plant (None: an ideal one), faults, seed.

    ``faults`` is link-specific (for the Jaguar: :class:`odolab.robot.jaguar.board.Faults`).
    """

    plant: PlantFactory | None = None
    faults: object | None = None
    seed: int = 0
    report_rate: float = 10.0


@dataclass(frozen=True, eq=False)
class RobotLink:
    """An open link: its driver, a description, the true pose (virtual robots) and a closer."""

    driver: Driver
    description: str
    true_pose: Callable[[], Pose | None]
    close: Callable[[], None]


#: opener(url, config, nominal params, clock, virtual) -> an open link
LinkOpener = Callable[[str, RunConfig, RobotParams, Clock, VirtualSpec], RobotLink]


def _jaguar_udp(
    url: str, config: RunConfig, params: RobotParams, clock: Clock, virtual: VirtualSpec
) -> RobotLink:
    from odolab.robot.jaguar.links import open_udp

    return open_udp(url, config, params, clock)


def _jaguar_virtual(
    url: str, config: RunConfig, params: RobotParams, clock: Clock, virtual: VirtualSpec
) -> RobotLink:
    from odolab.robot.jaguar.links import open_virtual

    return open_virtual(url, config, params, clock, virtual)


LINKS: dict[str, LinkOpener] = {"udp": _jaguar_udp, "sim": _jaguar_virtual}


def check_robot_url(url: str | None) -> str:
    """The URL (``sim://`` for None) if its scheme is registered; else :class:`RobotUrlError`."""
    url = DEFAULT_ROBOT_URL if url is None else url
    scheme = urlparse(url).scheme
    if scheme not in LINKS:
        raise RobotUrlError(
            f"--robot {url!r} has no known scheme; expected udp://HOST:PORT or sim://"
        )
    if scheme == "udp":
        from odolab.robot.jaguar.driver import parse_robot_url

        parse_robot_url(url)
    if scheme == "sim" and url != DEFAULT_ROBOT_URL:  # a host, a query: nothing reads them
        raise RobotUrlError(
            f"--robot {url!r}: expected plain sim:// (a virtual Jaguar on 127.0.0.1; its true "
            "behaviour is --truth)"
        )
    return url


def open_link(
    url: str | None,
    config: RunConfig,
    params: RobotParams,
    clock: Clock,
    virtual: VirtualSpec | None = None,
) -> RobotLink:
    """Open the link ``url`` names (None: a virtual robot)."""
    url = check_robot_url(url)
    return LINKS[urlparse(url).scheme](url, config, params, clock, virtual or VirtualSpec())
