"""RayPool.records' answers to workers that cannot be reached, on a stand-in for Ray whose calls
answer as the test says (no cluster: a lost node is an ActorUnavailableError, as Ray raises it while
it has not yet made the worker again elsewhere). tests/test_batch.py runs the pool on a real Ray;
killing a node there was too slow and flaky for the suite (docs/batch.md)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import pytest

from depthimpostor.batch import run
from depthimpostor.batch.run import RayPool
from depthimpostor.batch.worker import FAILED, RENDERED


class RayError(Exception):
    pass


class ActorUnavailableError(RayError):
    pass


class RayActorError(RayError):
    pass


@dataclass(eq=False)  # hashed by identity, as Ray's object references are told apart
class Future:
    answer: Callable[[], Any]


class FakeRay:
    """ray.wait (the first of the futures, in order), ray.get and ray.exceptions."""

    exceptions = SimpleNamespace(RayError=RayError, ActorUnavailableError=ActorUnavailableError,
                                 RayActorError=RayActorError)

    @staticmethod
    def wait(futures: list[Future], num_returns: int = 1, timeout: float | None = None
             ) -> tuple[list[Future], list[Future]]:
        silent = [future for future in futures if future.answer is never]
        answering = [future for future in futures if future.answer is not never]
        if not answering:  # Ray's wait: none ready before the timeout (for ever without one)
            assert timeout is not None, "ray.wait would wait for ever"
            time.sleep(timeout)
            return [], silent
        return answering[:num_returns], answering[num_returns:] + silent

    @staticmethod
    def get(future: Future) -> Any:
        return future.answer()


class Silent:
    def remote(self, *args: Any) -> Future:
        return Future(never)


class Call:
    def __init__(self, answer: Callable[..., Any]) -> None:
        self._answer = answer

    def remote(self, *args: Any) -> Future:
        return Future(lambda: self._answer(*args))


def unreachable() -> Any:
    raise ActorUnavailableError("its node cannot be reached")


def never() -> Any:
    raise AssertionError("a call that never answers was read")


class Worker:
    """An actor whose node is reachable or lost (`lost`), which records the frames it drew."""

    def __init__(self, name: str, lost: bool, silent: bool = False) -> None:
        self.name, self.drawn = name, []
        self.run = Call(lambda frame: unreachable() if lost else self._draw(frame))
        # A silent worker's "are you back?" never answers (Ray queues calls to an actor it keeps
        # making again where no node has room).
        self.pid = Call(lambda: unreachable() if lost else 1) if not silent else Silent()

    def _draw(self, frame: FrameTask) -> dict[str, Any]:
        self.drawn.append(frame.number)
        return {**frame.settings(), "status": RENDERED, "worker": self.name}


@dataclass(frozen=True)
class FrameTask:
    number: int

    def settings(self) -> dict[str, Any]:
        return {"frame": self.number}


def pool(*workers: Worker) -> RayPool:
    made = RayPool.__new__(RayPool)  # without starting Ray: the stand-in answers its calls
    made._ray = FakeRay()
    made.actors = list(workers)
    return made


def test_a_lost_workers_frames_go_to_the_others(monkeypatch: pytest.MonkeyPatch) -> None:
    """Frames sent to a worker whose node is lost are sent again to a reachable one; every frame
    comes back drawn, once."""
    monkeypatch.setattr(run, "UNREACHABLE_PAUSE", 0.0)
    lost, kept = Worker("lost", lost=True), Worker("kept", lost=False)
    records = list(pool(lost, kept).records([FrameTask(k) for k in range(6)]))
    assert sorted(record["frame"] for record in records) == list(range(6))
    assert all(record["status"] == RENDERED and record["worker"] == "kept" for record in records)
    assert sorted(kept.drawn) == list(range(6))


def test_the_pool_gives_up_when_no_worker_can_be_reached(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every worker lost and none made again: the frames left fail with the reason after
    UNREACHABLE_LIMIT, instead of the pool asking the workers for ever."""
    monkeypatch.setattr(run, "UNREACHABLE_PAUSE", 0.001)
    monkeypatch.setattr(run, "UNREACHABLE_LIMIT", 0.05)
    records = list(pool(Worker("a", lost=True), Worker("b", lost=True)).records([FrameTask(k) for k in range(5)]))
    assert sorted(record["frame"] for record in records) == list(range(5))
    assert all(record["status"] == FAILED for record in records)
    assert all("no worker reachable for" in record["error"] for record in records)


def test_the_deadline_holds_when_a_lost_worker_never_answers(monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker whose "are you back?" neither answers nor fails (Ray queues it): the pool's wait is
    bounded by UNREACHABLE_LIMIT, and the frames fail instead of the batch hanging."""
    monkeypatch.setattr(run, "UNREACHABLE_PAUSE", 0.001)
    monkeypatch.setattr(run, "UNREACHABLE_LIMIT", 0.05)
    records = list(pool(Worker("silent", lost=True, silent=True)).records([FrameTask(k) for k in range(3)]))
    assert sorted(record["frame"] for record in records) == [0, 1, 2]
    assert all(record["status"] == FAILED and "no worker reachable for" in record["error"] for record in records)
