"""Many runs on Dask distributed: a local cluster by default, any cluster by its address.

:func:`map_outcomes` runs ``func`` on every item and returns one :class:`Outcome` per item, in
order: the result, or the error of that item alone (one sentence), never losing the others. A
worker that dies mid-run loses only time: the scheduler runs its tasks again elsewhere (Dask's
``allowed-failures``), and the loss is reported in :attr:`MapReport.lost_workers`.

``Cluster(workers=1)`` (or a single item) runs everything here, in this process, with no Dask;
so does ``Cluster()`` (no scheduler, no number of workers) for fewer than
:data:`IN_PROCESS_BELOW` items, and for more where the first :data:`PROBE_ITEMS` say that all
of them take less than :data:`LOCAL_CLUSTER_PAYS_S` here; the report says which and why
(:meth:`Cluster.where`, :meth:`Cluster.after_probe`).

Inside :func:`one_local_cluster`, the maps that start a local cluster share one: a command that
maps twice (``calibrate lsq``: the fitted runs, then the held-out ones) starts it once.
"""

from __future__ import annotations

import logging
import os
import statistics
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Generic, TypeVar

from odolab.core.errors import OdolabError, opt
from odolab.core.progress import Progress

if TYPE_CHECKING:
    from distributed import Client, LocalCluster
    from distributed.security import Security

__all__ = [
    "DEFAULT_WORKERS",
    "IN_PROCESS_BELOW",
    "LOCAL_CLUSTER_PAYS_S",
    "PROBE_ITEMS",
    "Cluster",
    "MapReport",
    "Outcome",
    "local_cluster",
    "map_outcomes",
    "one_local_cluster",
]

T = TypeVar("T")
R = TypeVar("R")


#: With no scheduler and no number of workers given, fewer items than this run in this process:
#: a local cluster's start (2-3 s: its processes, their imports, its certificate) takes longer
#: than they do (docs/scale.md: 118-141 runs/s in the command's process against 61-85 on a local
#: cluster of 2, its start included, for 2,000 runs on 2 cores).
IN_PROCESS_BELOW = 64
#: With no scheduler and no number of workers given and :data:`IN_PROCESS_BELOW` items or more,
#: this many run here first, timed; the rest run here too where all of them would take less
#: than :data:`LOCAL_CLUSTER_PAYS_S` here (:meth:`Cluster.after_probe`).
PROBE_ITEMS = 8
#: Seconds of work in this process from which a local cluster of :data:`DEFAULT_WORKERS` is
#: started for the rest. On this 2-core machine the command's process was still faster for 2,000
#: runs (14-17 s of work against 23-33 s on the cluster, its start included: docs/scale.md), and
#: the DRIVE Husky's 603 two-second windows took 13 s of CPU here against 23 s with the cluster
#: (tests/io/test_husky_worked_example.py). Where the work is longer (not measured here), the
#: cluster's start is under a tenth of it and its two workers share the rest.
LOCAL_CLUSTER_PAYS_S = 30.0
#: Worker processes of a local cluster when none are given.
DEFAULT_WORKERS = 2


@dataclass(frozen=True)
class Cluster:
    """Where many runs are computed.

    ``scheduler``: a Dask scheduler address (``tcp://HOST:PORT``, ``tls://``), used with Dask's
    own configuration (its TLS and authentication settings); None starts a local cluster of
    ``workers`` processes with one thread each, bound to 127.0.0.1, reached only with TLS and a
    certificate made for it (:func:`local_cluster`), and stops it afterwards. ``workers <= 1``
    with no scheduler: in this process. ``workers`` None (the default): in this process for
    fewer than :data:`IN_PROCESS_BELOW` items, and for more where they take less than
    :data:`LOCAL_CLUSTER_PAYS_S` here (timed on the first :data:`PROBE_ITEMS`), else a local
    cluster of :data:`DEFAULT_WORKERS`.
    ``timeout``: seconds to wait for the scheduler to answer.
    """

    scheduler: str | None = None
    workers: int | None = None
    timeout: float = 30.0

    def __post_init__(self) -> None:
        if self.scheduler is not None and not self.scheduler.startswith(("tcp://", "tls://")):
            raise OdolabError(
                option="scheduler",
                value=self.scheduler,
                allowed="an address like tcp://HOST:PORT",
            )
        w = self.workers
        if w is not None and (isinstance(w, bool) or int(w) != w or w < 1):
            raise OdolabError(
                option="workers",
                value=self.workers,
                allowed="a whole number >= 1",
            )

    @property
    def local(self) -> bool:
        """True when nothing leaves this process, whatever the number of items."""
        return self.scheduler is None and self.workers is not None and self.workers <= 1

    def here_for(self, count: int) -> bool:
        """Whether ``count`` items run in this process before any is timed: where odolab chooses
        (:meth:`chooses`) and this is False, the first items' time decides
        (:meth:`after_probe`)."""
        if self.scheduler is not None:
            return False
        if self.workers is None:
            return count < IN_PROCESS_BELOW
        return self.workers <= 1 or count <= 1

    def describe(self) -> str:
        """Short text for a terminal: where many items run."""
        if self.scheduler is not None:
            return f"Dask cluster at {self.scheduler}"
        if self.local:
            return "this process"
        return f"local Dask cluster, {self.workers or DEFAULT_WORKERS} worker processes"

    def chooses(self, count: int) -> bool:
        """Whether odolab chooses where ``count`` items run (no scheduler, no workers given)."""
        return self.scheduler is None and self.workers is None and count > 1

    def after_probe(
        self, count: int, seconds: Sequence[float], probed: int | None = None
    ) -> tuple[bool, str]:
        """Whether ``count`` items run here after the first took ``seconds`` each here (the rule
        of :data:`LOCAL_CLUSTER_PAYS_S`), and where they run, in words, with why. The median
        item stands for all: the first pays what a process loads once (a reader, the kernels).
        ``seconds``: of the ``probed`` first items (default: as many), those that ran (a refused
        file takes no time)."""
        each = statistics.median(seconds) if seconds else 0.0
        estimate = each * count
        probed = len(seconds) if probed is None else probed
        ran = "" if probed == len(seconds) else f" of the {len(seconds)} that ran"
        timed = (
            f"{count} runs: the first {probed} took {_duration(each)} each here (median{ran}), "
            f"all of them about {_duration(estimate)}"
        )
        if estimate < LOCAL_CLUSTER_PAYS_S:
            return True, (
                f"this process ({timed}, less than the {LOCAL_CLUSTER_PAYS_S:g} s from which a "
                f"local Dask cluster pays; {opt('workers')} 2 starts one)"
            )
        return False, (
            f"{self.describe()} ({timed}, {LOCAL_CLUSTER_PAYS_S:g} s or more; "
            f"{opt('workers')} 1 keeps them in this process)"
        )

    def where(self, count: int) -> str:
        """Where ``count`` items run, in words, with the reason when odolab chose it."""
        if not self.chooses(count):
            return "this process" if self.here_for(count) else self.describe()
        if self.here_for(count):
            return (
                f"this process ({count} runs, fewer than {IN_PROCESS_BELOW}: a local Dask "
                f"cluster would take longer to start than they take; {opt('workers')} 2 starts one)"
            )
        return (
            f"this process or a local Dask cluster ({count} runs, {IN_PROCESS_BELOW} or more: "
            f"the first {PROBE_ITEMS}, timed here, decide)"
        )


def _duration(seconds: float) -> str:
    """``seconds`` for a sentence: 1.1 ms, 0.25 s, 29.6 s, 2,000 s."""
    if seconds < 0.1:
        return f"{seconds * 1e3:.2g} ms"
    if seconds < 10:
        return f"{seconds:.2g} s"
    if seconds < 100:
        return f"{seconds:.1f} s"
    return f"{seconds:,.0f} s"


@dataclass(frozen=True)
class Outcome(Generic[R]):
    """One item's result, or its error (``error`` one sentence, ``kind`` the exception class)."""

    label: str
    result: R | None = None
    error: str | None = None
    kind: str | None = None
    worker: str | None = None
    exception: BaseException | None = field(default=None, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """True when the item has a result."""
        return self.error is None


@dataclass
class MapReport:
    """What happened on the cluster: where, how long, which workers were lost."""

    where: str
    #: whether odolab chose where (:meth:`Cluster.chooses`): then ``where`` says why, and the
    #: faces say it
    chosen: bool = False
    seconds: float = 0.0
    workers_seen: set[str] = field(default_factory=set)
    lost_workers: list[str] = field(default_factory=list)

    def loss_text(self) -> str:
        """One sentence about lost workers ('' when none)."""
        if not self.lost_workers:
            return ""
        return (
            f"{len(self.lost_workers)} worker(s) lost during the run "
            f"({', '.join(sorted(self.lost_workers))}); their runs were computed again elsewhere"
        )


def _describe(err: BaseException) -> str:
    if isinstance(err, OdolabError):
        return str(err)
    text = str(err) or type(err).__name__
    return f"{type(err).__name__}: {text}"


def _worker_name() -> str | None:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return None


def _run_one(func: Callable[[T], R], item: T, label: str) -> Outcome[R]:
    """Run ``func(item)`` and catch its error: one item's failure is that item's outcome."""
    try:
        return Outcome(label, func(item), worker=_worker_name())
    except MemoryError:
        raise
    except Exception as err:
        if not isinstance(err, OdolabError):
            logging.getLogger("odolab").debug("%s failed:\n%s", label, traceback.format_exc())
        text = _describe(err)
        if label not in text:  # every failure names its run
            text = f"{label}: {text}"
        return Outcome(label, None, text, type(err).__name__, _worker_name(), err)


def _run_batch(func: Callable[[T], R], items: list[T], labels: list[str]) -> list[Outcome[R]]:
    """Several items in one task, each with its own outcome."""
    return [_run_one(func, item, name) for item, name in zip(items, labels, strict=True)]


@contextmanager
def _client(cluster: Cluster) -> Iterator[Client]:
    from distributed import Client

    if cluster.scheduler is not None:
        try:
            client = Client(cluster.scheduler, timeout=cluster.timeout)
        except OSError as err:
            raise OdolabError(
                f"no Dask scheduler answers at {cluster.scheduler} ({err}); expected "
                "`dask scheduler` running there"
            ) from err
        with client:
            yield client
        return
    workers = cluster.workers or DEFAULT_WORKERS
    kept = _KEPT.get()
    if kept is None:
        with local_cluster(workers) as local, Client(local) as client:
            yield client
        return
    shared = kept.clusters.get(workers)
    if shared is None:  # the first map of the block that needs one starts it; the block stops it
        shared = kept.clusters[workers] = kept.stack.enter_context(local_cluster(workers))
    with Client(shared) as client:
        yield client


@dataclass
class _Kept:
    """The local clusters of a :func:`one_local_cluster` block, by their number of workers."""

    stack: ExitStack
    clusters: dict[int, LocalCluster] = field(default_factory=dict)


_KEPT: ContextVar[_Kept | None] = ContextVar("odolab_kept_local_cluster", default=None)


@contextmanager
def one_local_cluster() -> Iterator[None]:
    """Within the block, every map that would start a local Dask cluster of the same size uses
    one: the first that needs it starts it, and the block's end stops it (no map that stays in
    this process or goes to a scheduler starts anything); meanwhile, between the maps, it stays
    up idle. Each start costs 2-3 s and its worker processes' imports; ``calibrate lsq`` paid it
    twice, for its fitted and its held-out runs. Maps of another size start their own, which
    also stops at the end. One block to a thread (the clusters are not shared between
    threads)."""
    kept = _Kept(ExitStack())
    token = _KEPT.set(kept)
    try:
        with kept.stack:
            yield
    finally:
        _KEPT.reset(token)


def _security() -> Security:
    """TLS with a certificate made for this cluster alone (kept in memory, never on disk)."""
    from distributed.security import Security

    try:
        security: Security = Security.temporary()  # (distributed is untyped)
        return security
    except ImportError as err:  # pragma: no cover - cryptography is a dependency
        raise OdolabError(
            "the local Dask cluster needs the package `cryptography` for its TLS certificate; "
            "expected it installed with odolab (pip install cryptography), or use {{workers}} 1"
        ) from err


@contextmanager
def local_cluster(workers: int) -> Iterator[LocalCluster]:
    """A Dask cluster on this machine that no other process can use.

    ``workers`` processes with one thread each. Every listening port (scheduler, nannies,
    workers) speaks TLS with mutual authentication: a certificate and key made for this cluster
    (:meth:`distributed.security.Security.temporary`) that only this process and its workers
    hold, so another local process (another user, a browser page, a stranger's script) cannot
    connect, let alone run a function. The scheduler's and workers' web servers (dashboard,
    metrics, health) serve no route at all. Everything listens on 127.0.0.1 only.
    """
    import dask
    from distributed import LocalCluster

    with (
        dask.config.set(
            {"distributed.scheduler.http.routes": [], "distributed.worker.http.routes": []}
        ),
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            protocol="tls://",
            security=_security(),
            # the scheduler's web server on a free loopback port: None meant distributed's
            # default 127.0.0.1:8787, and two odolab runs at once warned
            dashboard_address="127.0.0.1:0",
            # odolab's own output stays odolab's: a worker that outlives the scheduler at
            # shutdown logs "Failed to communicate with scheduler during heartbeat" (40 lines
            # with the traceback) at ERROR; what fails is reported by odolab (Outcome)
            silence_logs=logging.CRITICAL,
        ) as local,
    ):
        yield local


def map_outcomes(
    func: Callable[[T], R],
    items: Sequence[T],
    *,
    cluster: Cluster | None = None,
    progress: Progress | None = None,
    label: Callable[[T], str] = str,
    report: MapReport | None = None,
    batch: int | None = None,
) -> list[Outcome[R]]:
    """``func`` on every item (in order), on ``cluster``; one :class:`Outcome` per item.

    ``func`` must be importable by the workers (a module-level function). ``progress(done,
    total, label)`` is called as results arrive. ``report`` (optional) is filled with where the
    work ran, its duration and the workers lost on the way. ``batch``: items per Dask task
    (default: up to 32, at least 4 tasks per worker).
    """
    c = cluster or Cluster()
    total = len(items)
    rep = report if report is not None else MapReport(c.where(total))
    rep.where = c.where(total)
    rep.chosen = c.chooses(total)
    labels = [label(x) for x in items]
    t0 = time.perf_counter()
    out: list[Outcome[R]] = []
    took: list[float] = []

    def here(upto: int) -> None:
        for k in range(len(out), upto):
            start = time.perf_counter()
            out.append(_run_one(func, items[k], labels[k]))
            took.append(time.perf_counter() - start)
            if progress is not None:
                progress(k + 1, total, labels[k])

    stay = c.here_for(total)
    if not stay and c.chooses(total):  # odolab's choice: a few here first, timed
        here(min(PROBE_ITEMS, total))
        worked = [s for s, o in zip(took, out, strict=True) if o.ok]
        stay, rep.where = c.after_probe(total, worked or took, len(took))
    if stay:
        here(total)
    else:
        out = _on_cluster(c, func, items, labels, out, progress, rep, batch)
    rep.seconds = time.perf_counter() - t0
    return out


def _on_cluster(
    c: Cluster,
    func: Callable[[T], R],
    items: Sequence[T],
    labels: list[str],
    done_here: list[Outcome[R]],
    progress: Progress | None,
    rep: MapReport,
    batch: int | None,
) -> list[Outcome[R]]:
    """:func:`map_outcomes`' items after ``done_here`` (the first, run here) on ``c``."""
    from distributed import as_completed

    total, first = len(items), len(done_here)
    with _client(c) as client:
        start_workers = set(client.scheduler_info().get("workers", {}))
        rep.workers_seen |= start_workers
        # a few items per task: Dask's per-task cost (~ms) stays small beside the work; still
        # several tasks per worker, so a lost worker's share is small and spread when recomputed
        size = batch or max(1, min(32, (total - first) // (4 * max(1, len(start_workers)))))
        spans = [(k, min(k + size, total)) for k in range(first, total, size)]
        futures = client.map(
            _run_batch,
            [func] * len(spans),
            [list(items[a:b]) for a, b in spans],
            [labels[a:b] for a, b in spans],
            pure=False,
            key=[f"odolab-{os.getpid()}-{id(items)}-{a}" for a, _ in spans],
        )
        index = {f.key: j for j, f in enumerate(futures)}
        results: list[Outcome[R] | None] = [*done_here, *([None] * (total - first))]
        done = first
        for fut in as_completed(futures):
            a, b = spans[index[fut.key]]
            try:
                results[a:b] = fut.result()
            except Exception as err:  # the task itself failed for good (KilledWorker, ...)
                text, kind = _describe(err), type(err).__name__
                results[a:b] = [
                    Outcome(labels[k], None, text, kind, None, err) for k in range(a, b)
                ]
            done += b - a
            if progress is not None:
                progress(done, total, labels[b - 1])
            rep.workers_seen |= set(client.scheduler_info().get("workers", {}))
        now = set(client.scheduler_info().get("workers", {}))
        rep.workers_seen |= {o.worker for o in results if o is not None and o.worker}
        rep.lost_workers = sorted(rep.workers_seen - now)
    return [o for o in results if o is not None]
