"""Robot links by the scheme of the ``--robot`` URL (an explicit registry, no discovery).

=========================  ==========================================================
``udp://HOST:PORT``        a Jaguar board over UDP, binary frames (:mod:`odolab.robot.jaguar`)
``tcp://HOST:PORT``        a Jaguar 4x4 of 2014 or later, text lines over TCP
                           (:mod:`odolab.robot.jaguar2014`)
``sim://`` (the default)   a virtual Jaguar board started on 127.0.0.1 for the run
=========================  ==========================================================

A new kind of robot is one package that implements :class:`odolab.robot.interface.Driver`, an
opener and a URL check, plus one row in :data:`LINKS` (and one in :data:`IN_PROCESS` for runs in
simulated time). Links never import this module: the table imports them, lazily.
"""

from __future__ import annotations

import socket
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from urllib.parse import urlparse

from odolab.core.defaults import DEFAULT_SEED, DEFAULT_TERRAIN, DEFAULT_TRUTH
from odolab.core.errors import opt
from odolab.core.params import RobotParams
from odolab.robot.clock import Clock, SimClock
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotConfigError, RobotUrlError
from odolab.robot.interface import RobotLink, VirtualSpec
from odolab.robot.plant import Plant

__all__ = [
    "DEFAULT_ROBOT_URL",
    "IN_PROCESS",
    "LINKS",
    "VIRTUAL_ONLY",
    "InProcessOpener",
    "LinkEntry",
    "LinkOpener",
    "RobotLink",
    "VirtualSpec",
    "check_robot_url",
    "check_virtual_only",
    "open_in_process",
    "open_link",
]

DEFAULT_ROBOT_URL = "sim://"

#: opener(url, config, nominal params, clock, virtual) -> an open link
LinkOpener = Callable[[str, RunConfig, RobotParams, Clock, VirtualSpec], RobotLink]
#: opener(config, nominal params, simulated clock, plant, virtual) -> a link in simulated time
InProcessOpener = Callable[[RunConfig, RobotParams, SimClock, Plant, VirtualSpec], RobotLink]


@dataclass(frozen=True)
class LinkEntry:
    """One row of :data:`LINKS`: the URL's form for people, its check and the opener."""

    form: str  #: e.g. "udp://HOST:PORT (a Jaguar board, binary over UDP)"
    check: Callable[[str], object]  #: raises RobotUrlError for a URL of this scheme it refuses
    open: LinkOpener


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


def _jaguar2014_tcp(
    url: str, config: RunConfig, params: RobotParams, clock: Clock, virtual: VirtualSpec
) -> RobotLink:
    from odolab.robot.jaguar2014.links import open_tcp

    return open_tcp(url, config, params, clock)


def _check_udp(url: str) -> object:
    from odolab.robot.jaguar.driver import parse_robot_url

    return parse_robot_url(url)


def _check_tcp(url: str) -> object:
    from odolab.robot.jaguar2014.driver import parse_tcp_url

    return parse_tcp_url(url)


def _check_sim(url: str) -> object:
    if url != DEFAULT_ROBOT_URL:  # a host, a query: nothing reads them
        raise RobotUrlError(
            f"{opt('robot')} {url!r}: expected plain sim:// (a virtual Jaguar on 127.0.0.1; its "
            "true behaviour is {{truth}})"
        )
    return url


LINKS: dict[str, LinkEntry] = {
    "udp": LinkEntry("udp://HOST:PORT (a Jaguar board, binary over UDP)", _check_udp, _jaguar_udp),
    "tcp": LinkEntry(
        "tcp://HOST:PORT (a Jaguar 4x4 of 2014 or later, text over TCP)",
        _check_tcp,
        _jaguar2014_tcp,
    ),
    "sim": LinkEntry("sim:// (a virtual Jaguar on 127.0.0.1)", _check_sim, _jaguar_virtual),
}


def _jaguar_in_process(
    config: RunConfig, params: RobotParams, clock: SimClock, plant: Plant, virtual: VirtualSpec
) -> RobotLink:
    from odolab.robot.jaguar.links import open_in_process as open_jaguar

    return open_jaguar(
        config, params, clock, plant,
        faults=virtual.faults, seed=virtual.seed, report_rate=virtual.report_rate,
    )  # fmt: skip


def _jaguar2014_in_process(
    config: RunConfig, params: RobotParams, clock: SimClock, plant: Plant, virtual: VirtualSpec
) -> RobotLink:
    from odolab.robot.jaguar2014.links import open_in_process as open_2014

    return open_2014(config, params, clock, plant, virtual)


#: Links that run in simulated time, in-process, over a plant: by link name.
IN_PROCESS: dict[str, InProcessOpener] = {
    "jaguar": _jaguar_in_process,
    "jaguar2014": _jaguar2014_in_process,
}


def check_robot_url(url: str | None) -> str:
    """The URL (``sim://`` for None) if its scheme is registered and the link takes it; else
    :class:`RobotUrlError`."""
    url = DEFAULT_ROBOT_URL if url is None else url
    _check_characters(url)  # (urlparse drops spaces around, and tabs and line ends inside)
    scheme = urlparse(url).scheme
    if scheme not in LINKS:
        forms = ", ".join(entry.form for entry in LINKS.values())
        raise RobotUrlError(f"{opt('robot')} {url!r} has no known scheme; expected one of {forms}")
    LINKS[scheme].check(url)
    _check_host(url)
    return url


def _check_characters(url: str) -> None:
    bad = next((i for i, c in enumerate(url) if c.isspace() or not c.isprintable()), None)
    if bad is not None:
        raise RobotUrlError(
            f"{opt('robot')} {url!r} has a space or control character at position {bad + 1}; "
            "expected the URL alone (SCHEME://HOST:PORT, nothing around it)"
        )


def _check_host(url: str) -> None:
    """Refuse an IPv4 address written other than as four decimal numbers (``0x7f000001``,
    ``2130706433``, ``127.1``, ``0177.0.0.1``): the resolver takes them for an address a
    reader of the command line does not see."""
    host = urlparse(url).hostname
    if not host or ":" in host:  # none (sim://), or an IPv6 literal
        return
    try:
        packed = socket.inet_aton(host)
    except OSError:  # a name
        return
    dotted = socket.inet_ntoa(packed)
    if dotted != host:
        raise RobotUrlError(
            f"{opt('robot')} {url!r}: the host {host!r} is the IPv4 address {dotted} written another "
            f"way; expected it as four decimal numbers ({dotted}) or a host name"
        )


#: The settings (library names) that only the virtual board started for a ``sim://`` run
#: reads, with their defaults: on a real link, one that is not its default is refused before anything is sent
#: (a user who means the simulator must not drive the robot instead).
VIRTUAL_ONLY: dict[str, object] = {
    "truth": DEFAULT_TRUTH,
    "terrain": DEFAULT_TERRAIN,
    "seed": DEFAULT_SEED,
    "command_timeout": next(f.default for f in fields(RunConfig) if f.name == "command_timeout"),
}


def check_virtual_only(url: str, given: Mapping[str, object]) -> None:
    """Refuse options of :data:`VIRTUAL_ONLY` that differ from their defaults (``given``:
    setting -> value) when ``url`` is a real link (one sentence, naming them)."""
    if urlparse(url).scheme == "sim":
        return
    changed = [k for k, v in given.items() if k in VIRTUAL_ONLY and v != VIRTUAL_ONLY[k]]
    if changed:
        one = len(changed) == 1
        raise RobotConfigError(
            f"{', '.join(map(opt, changed))} {'is' if one else 'are'} for the virtual Jaguar (sim://) "
            f"only, and the robot is {url}: nothing was sent; leave {'it' if one else 'them'} "
            "out to drive this robot (a real board has its own command timeout), or use "
            "{{robot}} sim:// to drive the simulator"
        )


def open_link(
    url: str | None,
    config: RunConfig,
    params: RobotParams,
    clock: Clock,
    virtual: VirtualSpec | None = None,
) -> RobotLink:
    """Open the link ``url`` names (None: a virtual robot)."""
    url = check_robot_url(url)
    return LINKS[urlparse(url).scheme].open(url, config, params, clock, virtual or VirtualSpec())


def open_in_process(
    link: str,
    config: RunConfig,
    params: RobotParams,
    clock: SimClock,
    plant: Plant,
    virtual: VirtualSpec | None = None,
) -> RobotLink:
    """The virtual board of link ``link`` (a key of :data:`IN_PROCESS`) over ``plant``, wired to
    its driver in-process, in ``clock``'s time."""
    if link not in IN_PROCESS:
        raise RobotUrlError(
            f"no in-process link {link!r}; expected one of {', '.join(sorted(IN_PROCESS))}"
        )
    return IN_PROCESS[link](config, params, clock, plant, virtual or VirtualSpec())
