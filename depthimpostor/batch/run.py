"""Frames rendered by a pool of workers: Ray actors on this machine or a cluster, or this process.

Ray (docs/batch.md says why Ray): each worker is an actor, a process that keeps its GL context and
its renderers for its lifetime (worker.py), asking for one CPU (and one GPU where the cluster has
GPUs; the actor then makes its context on the EGL device of its GPU). Frames go to the actors a few
at a time each (FRAMES_IN_FLIGHT) and come back in the order they finish. A worker process that
dies is restarted and the frames it held are sent again (Ray's max_restarts and max_task_retries:
RETRIES); a frame whose files were written before the death is then found complete, not drawn
again. A worker whose node is lost cannot be reached until Ray has noticed and made it again on
another node: the frames it held go to the other workers meanwhile. A frame that fails (a bad
scene) comes back as a record saying why; the others go on.

`run_batch` writes the manifest: one JSON line per frame as it completes (its settings, the worker,
its timings, the renderer's figures), appended and flushed line by line, so that a batch killed
half-way keeps the lines of every frame it finished, and a rerun adds only the frames it draws.
"""

from __future__ import annotations

import json
import os
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from tqdm import tqdm

from ..errors import DepthImpostorError, OutputError, SceneError
from ..gpu.context import Backend, egl_device_for_gpu
from .jobs import Frame
from .worker import FAILED, FOUND, RENDERED, FrameWorker, Task, complete, one_line

#: Frames held by each worker at a time: one drawing and one waiting, so that a worker never
#: waits for the driver between frames, and a dead worker takes few frames with it.
FRAMES_IN_FLIGHT = 2
#: How often a dead worker process is restarted, and a frame it held sent again.
RETRIES = 3
#: Seconds between questions to a worker that could not be reached (its node lost), while Ray
#: notices the loss and makes the worker again elsewhere.
UNREACHABLE_PAUSE = 0.5
#: Seconds the pool waits with every worker it has left unreachable and no frame drawing before it
#: fails the frames left ("no worker reachable"): Ray notices a lost node in about half a minute
#: and makes its workers again on a node with room within seconds of that; a cluster with no room
#: left, or a worker Ray never makes again, would otherwise keep the batch waiting for ever.
UNREACHABLE_LIMIT = 300.0
#: The `batch` extra: what to install when Ray is missing.
RAY_HINT = 'pip install "depthimpostor[batch]" (Ray); or --workers 0 to render in this process'


class FramePool:
    """Where frames are rendered; `records(frames)` yields each frame's record as it completes.
    A frame is any worker.Task: a batch's jobs.Frame, or a configuration of `bench --workers`."""

    workers = 1
    description = "this process"

    def records(self, frames: Sequence[Task]) -> Iterator[dict[str, Any]]:
        raise NotImplementedError

    def __enter__(self) -> FramePool:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        pass


class LocalPool(FramePool):
    """One FrameWorker in this process, frames in order (`--workers 0`; the tests' serial reference)."""

    def __init__(self, backend: Backend | None = None, max_memory: int | None = None) -> None:
        self.worker = FrameWorker(backend, None, max_memory)

    def records(self, frames: Sequence[Task]) -> Iterator[dict[str, Any]]:
        for frame in frames:
            yield self.worker.run(frame)

    def close(self) -> None:
        self.worker.release()


class RayWorker(FrameWorker):
    """A FrameWorker in a Ray actor: its context on its GPU's EGL device where Ray gave it one
    (gpu/context.py choose_egl_device)."""

    def __init__(self, backend: Backend | None, max_memory: int | None, threads: int | None) -> None:
        import ray

        gpus: list[Any] = ray.get_gpu_ids()
        # Mesa's llvmpipe rasterizes with a thread per core; workers sharing the cores each get their share.
        if threads is not None and not gpus:
            os.environ.setdefault("LP_NUM_THREADS", str(threads))
        # Ray gave this process its GPU (CUDA_VISIBLE_DEVICES); EGL's device of that GPU is found
        # by its CUDA device number where the driver says it, EGL's order need not be CUDA's.
        choice = egl_device_for_gpu(str(gpus[0])) if gpus else None
        super().__init__(backend, choice.index if choice is not None else None, max_memory)
        self.device_choice = choice.how if choice is not None else None
        self.node = ray.get_runtime_context().get_node_id()

    def identity(self) -> dict[str, Any]:
        """FrameWorker's, with the Ray node (a cluster's machines may share a host name) and how
        the EGL device was chosen."""
        where = super().identity() | {"node": self.node}
        return where | ({"device_choice": self.device_choice} if self.device_choice and "device" in where else {})

    def pid(self) -> int:
        return os.getpid()


class RayPool(FramePool):
    """Ray actors: on a local Ray started here (one per core, or `workers`), or on the cluster at `address`."""

    def __init__(self, workers: int | None = None, address: str | None = None, backend: Backend | None = None,
                 max_memory: int | None = None) -> None:
        try:
            import ray as ray_module
        except ImportError:
            raise SceneError("command line", "--workers", f"expected Ray to be installed: {RAY_HINT}") from None
        # Ray's hints cover part of its API (cluster_resources has none, an actor's methods are
        # typed as plain methods): it is used untyped.
        ray: Any = ray_module
        self._ray = ray
        self._started = not ray.is_initialized()
        if self._started:
            cores = os.cpu_count() or 1
            options: dict[str, Any] = {"include_dashboard": False, "logging_level": "ERROR",
                                       "configure_logging": True, "log_to_driver": True}
            if address is None:
                ray.init(num_cpus=workers or cores, **options)
            else:
                ray.init(address=address, **options)
        resources = ray.cluster_resources()
        gpus = int(resources.get("GPU", 0))
        self.workers = workers or gpus or int(resources.get("CPU", 1))
        threads = max(1, (os.cpu_count() or 1) // self.workers) if address is None else None
        # SPREAD: workers over the cluster's machines rather than packed onto the first ones (a
        # software rasterizer takes a machine's cores; a GPU worker asks for its GPU anyway).
        actor = ray.remote(num_cpus=1, num_gpus=1 if gpus else 0, max_restarts=RETRIES, max_task_retries=RETRIES,
                           scheduling_strategy="SPREAD")(RayWorker)
        self.actors: list[Any] = [actor.remote(backend, max_memory, threads) for _ in range(self.workers)]
        where = address or "a local Ray"
        self.description = f"{self.workers} Ray workers on {where}" + (f" ({gpus} GPUs)" if gpus else "")

    def records(self, frames: Sequence[Task]) -> Iterator[dict[str, Any]]:
        ray: Any = self._ray
        waiting = deque(enumerate(frames))
        sent = [0] * len(frames)  # how often each frame was sent (to a worker that could not be reached)
        held: dict[Any, tuple[int, Any]] = {}  # a frame's future: the frame and its actor
        unreachable: dict[Any, Any] = {}  # a call asking an unreachable actor whether it is back: the actor
        load = {id(actor): 0 for actor in self.actors}
        actors = list(self.actors)
        stalled_since: float | None = None  # since when no frame is drawing and every worker is unreachable
        while waiting or held:
            asked = set(map(id, unreachable.values()))
            for actor in (actor for actor in actors if id(actor) not in asked):
                while waiting and load[id(actor)] < FRAMES_IN_FLIGHT:
                    index, frame = waiting.popleft()
                    sent[index] += 1
                    held[actor.run.remote(frame)] = (index, actor)
                    load[id(actor)] += 1
            if not held and not unreachable:  # every worker died: what is left cannot be drawn
                for _, frame in waiting:
                    yield {**frame.settings(), "status": FAILED, "error": "no worker left (every one died)"}
                return
            stalled_since = None if held else stalled_since if stalled_since is not None else time.monotonic()
            if stalled_since is not None and time.monotonic() - stalled_since >= UNREACHABLE_LIMIT:
                for _, frame in waiting:
                    yield {**frame.settings(), "status": FAILED,
                           "error": f"no worker reachable for {UNREACHABLE_LIMIT:.0f} s (their machines lost)"}
                return
            # While stalled, no longer than the deadline: an unreachable worker's answer may never come.
            timeout = None if stalled_since is None else max(0.0, stalled_since + UNREACHABLE_LIMIT - time.monotonic())
            ready, _ = ray.wait([*held, *unreachable], num_returns=1, timeout=timeout)
            if not ready:
                continue  # the deadline passed: the check above fails what is left
            done = ready[0]
            if done in unreachable:
                self._answered(ray, done, unreachable, actors)
                continue
            index, actor = held.pop(done)
            load[id(actor)] -= 1
            try:
                yield ray.get(done)
            except ray.exceptions.ActorUnavailableError as error:
                # Its node cannot be reached (lost, or not yet known to be lost): Ray's retries of
                # the call are spent in seconds, before the actor is made again elsewhere. The frame
                # goes to another worker; this one gets none until it answers.
                if sent[index] > RETRIES:
                    yield {**frames[index].settings(), "status": FAILED, "error": f"worker unreachable: {one_line(error)}"}
                else:
                    waiting.appendleft((index, frames[index]))
                if actor in actors and id(actor) not in set(map(id, unreachable.values())):
                    unreachable[actor.pid.remote()] = actor
            except ray.exceptions.RayActorError as error:  # died RETRIES times: this worker is gone
                if actor in actors:
                    actors.remove(actor)
                yield {**frames[index].settings(), "status": FAILED, "error": f"worker died: {one_line(error)}"}
            except ray.exceptions.RayError as error:
                yield {**frames[index].settings(), "status": FAILED, "error": one_line(error)}

    @staticmethod
    def _answered(ray: Any, call: Any, unreachable: dict[Any, Any], actors: list[Any]) -> None:
        """An unreachable actor's answer: back (made again on a node with room), still unreachable
        (asked again: a restart waits for its node to be known lost), or gone for good."""
        actor = unreachable.pop(call)
        try:
            ray.get(call)
        except ray.exceptions.ActorUnavailableError:
            time.sleep(UNREACHABLE_PAUSE)
            unreachable[actor.pid.remote()] = actor
        except ray.exceptions.RayActorError:
            if actor in actors:  # gone for good
                actors.remove(actor)

    def close(self) -> None:
        for actor in self.actors:
            self._ray.kill(actor)
        self.actors = []
        if self._started:
            self._ray.shutdown()


def open_pool(workers: int | None, address: str | None, backend: Backend | None = None,
              max_memory: int | None = None) -> FramePool:
    """`--workers 0`: this process; otherwise Ray (a local one, or the cluster at `address`)."""
    if workers == 0:
        if address is not None:
            raise SceneError("command line", "--address", "expected with --workers 1 or more (0: this process)")
        return LocalPool(backend, max_memory)
    return RayPool(workers, address, backend, max_memory)


@dataclass
class BatchSummary:
    frames: int = 0
    rendered: int = 0
    found: int = 0
    failed: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0

    def failed_jobs(self) -> dict[str, tuple[int, str]]:
        """Each job with failed frames: how many, and the first one's error."""
        jobs: dict[str, tuple[int, str]] = {}
        for record in self.failed:
            count, error = jobs.get(record["job"], (0, record.get("error", "")))
            jobs[record["job"]] = (count + 1, error)
        return jobs


def recorded_outputs(manifest: Path) -> set[str]:
    """The outputs the manifest lists as complete (a line cut short by a kill is passed over)."""
    recorded: set[str] = set()
    if not manifest.is_file():
        return recorded
    for line in manifest.read_text(encoding="utf-8").splitlines():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if record.get("status") in (RENDERED, FOUND):
            recorded.update(record.get("outputs", []))
    return recorded


class Manifest:
    """JSON lines appended and flushed one at a time (a kill loses at most the line being written)."""

    def __init__(self, path: Path, run: str) -> None:
        self.path, self.run = path, run
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(path, "a", encoding="utf-8")  # noqa: SIM115 - closed by close()
            if self._file.tell() and not path.read_bytes().endswith(b"\n"):
                self._file.write("\n")  # after a line a kill cut short: the next starts on its own
        except OSError as error:
            raise OutputError(f"cannot write the manifest {path}: {error.strerror or error}") from None

    def write(self, record: dict[str, Any]) -> None:
        line = json.dumps({**{k: v for k, v in record.items() if k != "image"}, "run": self.run}, default=_plain)
        self._file.write(line + "\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        self._file.close()


def _plain(value: object) -> object:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON")


def run_batch(frames: Sequence[Frame], pool: FramePool, manifest: Path | None, progress: bool = True,
              on_record: Callable[[dict[str, Any]], None] | None = None) -> BatchSummary:
    """Render the frames not yet complete on `pool`, each record into the manifest as it comes.
    A frame complete on disk but missing from the manifest (its worker wrote it, then the batch
    was killed) is recorded as found, without drawing it."""
    started = time.perf_counter()
    summary = BatchSummary(frames=len(frames))
    run = f"{time.strftime('%Y-%m-%dT%H:%M:%S')}-{os.getpid()}"
    log = Manifest(manifest, run) if manifest is not None else None
    recorded = recorded_outputs(manifest) if manifest is not None else set()
    todo = []
    try:
        for frame in frames:
            if not complete(frame):
                todo.append(frame)
                continue
            summary.found += 1
            if log is not None and not {str(p) for p in frame.outputs} <= recorded:
                log.write({**frame.settings(), "status": FOUND})
        with tqdm(total=len(frames), initial=summary.found, unit="frame", disable=not progress,
                  desc=pool.description) as bar:
            for record in pool.records(todo):
                _count(summary, record)
                if log is not None:
                    log.write(record)
                if on_record is not None:
                    on_record(record)
                bar.update(1)
    finally:
        if log is not None:
            log.close()
    summary.seconds = time.perf_counter() - started
    return summary


def _count(summary: BatchSummary, record: dict[str, Any]) -> None:
    status = record["status"]
    if status == RENDERED:
        summary.rendered += 1
    elif status == FOUND:
        summary.found += 1
    else:
        summary.failed.append(record)


def in_order(records: Iterable[dict[str, Any]], count: int) -> Iterator[np.ndarray]:
    """The `image` of records that come in any order, yielded in frame order (0, 1, ...): a
    video's frames drawn out of order, assembled in order. A failed frame raises its error."""
    early: dict[int, np.ndarray] = {}
    wanted = 0
    for record in records:
        if record["status"] == FAILED:  # its error names the scene and field, or the worker's death
            raise DepthImpostorError(f"frame {record['frame']}: {record['error']}")
        early[record["frame"]] = record["image"]
        while wanted in early:
            yield early.pop(wanted)
            wanted += 1
    if wanted != count:
        raise OutputError(f"expected {count} frames, got {wanted}")
