"""`bench --workers N` (and `--address`): the benchmark's configurations on batch workers (run.py's pool).

Each configuration (scene x method x algorithm x resolution) is a task sent to a worker, which
keeps, as for a batch's frames, one GL context for its lifetime, each scene read once and the
scene's truth traced once (as the serial bench traces it once per scene, for the rays every
method shares), and makes the configuration's timed and measuring renderers, released after it
(their GL memory is the configuration's alone). The rows come back in any order and are put in
the serial bench's order, and written by the same functions (bench.write_results): the same
files, tables and columns.

What the figures mean: the accuracy columns are the serial bench's, exactly (the same renderers,
frames and truth). The timings are each worker's own, of its configuration timed alone while the
other workers draw theirs on the same machine (or cluster): they share its cores, caches and
memory bandwidth in whatever way the workers interleave, which is not the serial bench's rounds
(there, a scene's configurations take turns in one process). They say what a sweep costs on the
pool, not what one configuration costs on an idle machine.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..bench import (
    RESOLUTION_METHODS, BenchRow, BenchSettings, Technique, bench_configuration, header_lines, scene_configurations,
)
from ..errors import DepthImpostorError
from ..oracles.compare import TruthFrame
from ..plan import plan_render
from ..scene import Scene
from .run import FramePool
from .worker import FAILED, RENDERED, FrameWorker, one_line


@dataclass(frozen=True)
class BenchTask:
    """One configuration of the benchmark, as plain data (it travels to other machines)."""

    index: int  # its place among the serial bench's rows
    scene: str  # the scene file, absolute: read by the worker
    samples: int | None  # bench --samples (None: the scene's)
    resolution: int | str
    technique: Technique
    bench: BenchSettings

    @property
    def name(self) -> str:
        return Path(self.scene).stem

    def settings(self) -> dict[str, Any]:
        """As a record names the configuration (and a failed one's error message)."""
        return {"job": "bench", "frame": self.index, "scene": self.scene, "method": self.technique.method.option,
                "algorithm": self.technique.algorithm_name, "resolution": self.resolution}

    def variant(self, worker: FrameWorker) -> Scene:
        """The scene as the serial bench configures it: --samples, then the size and resolution."""
        scene = worker.scene(self.scene).with_overrides(samples=self.samples)
        return scene.with_overrides(size=self.bench.size, impostor_resolution=self.resolution)

    def run(self, worker: FrameWorker) -> dict[str, Any]:
        """Time and measure this configuration on `worker` (worker.Task); its record, with `row`."""
        record = self.settings()
        started = time.perf_counter()
        # The truth depends on the scene and the rays (its size and samples), not on the method
        # or resolution: bench.run_bench reuses it across a scene's configurations so.
        truth_key = ("bench truth", self.scene, self.samples, self.bench.size)
        try:
            kept = worker.recall(truth_key)
            figures, truth = bench_configuration(worker.ctx, self.variant(worker), self.technique, self.bench,
                                                 kept if isinstance(kept, TruthFrame) else None)
        except Exception as error:  # one configuration's failure (a GL limit) is reported; the worker goes on
            return {**record, "worker": worker.identity(), "status": FAILED, "error": one_line(error)}
        worker.keep(truth_key, truth)
        resolution = self.resolution if self.technique.method in RESOLUTION_METHODS else 0
        row = {"scene": self.name, "method": self.technique.method.option, "algorithm": self.technique.algorithm_name,
               "resolution": resolution, **figures}
        return {**record, "worker": worker.identity(), "status": RENDERED, "row": row,
                "seconds": round(time.perf_counter() - started, 6)}


def bench_tasks(scenes: Sequence[Scene], settings: BenchSettings, samples: int | None) -> list[BenchTask]:
    """Every configuration, in the serial bench's order; each refused here, before any worker
    starts, where its method refuses the scene (as the serial bench refuses it)."""
    tasks: list[BenchTask] = []
    for scene in scenes:
        source = str(Path(scene.source).resolve())
        for variant, resolution, technique in scene_configurations(scene, settings):
            plan_render(variant, technique.method, technique.algorithm)
            tasks.append(BenchTask(len(tasks), source, samples, resolution, technique, settings))
    return tasks


@dataclass
class PoolBench:
    """The rows of a bench run on a pool, in the serial order, and the header naming its workers."""

    rows: list[BenchRow]
    header: list[str]


def run_bench_on_pool(pool: FramePool, scenes: Sequence[Scene], settings: BenchSettings, samples: int | None,
                      progress: object | None = None) -> PoolBench:
    """Every configuration of bench.run_bench, on the pool's workers; `progress` a tqdm bar (or
    anything with update()). A configuration that fails (a GL limit of its worker's context, a
    worker that died RETRIES times) raises its one-line error: a table with a hole would mislead."""
    tasks = bench_tasks(scenes, settings, samples)
    rows: dict[int, BenchRow] = {}
    workers: list[dict[str, Any]] = []
    for record in pool.records(tasks):
        if record["status"] != RENDERED:
            task = tasks[record["frame"]]
            where = f"{task.name}, {task.technique.method.option}" + (
                "" if task.technique.algorithm_name == "-" else f" {task.technique.algorithm_name}")
            raise DepthImpostorError(f"bench: {where}, resolution {task.resolution}: "
                                     f"{record.get('error', record['status'])}")
        rows[record["frame"]] = BenchRow(**record["row"])
        workers.append(record.get("worker", {}))
        if progress is not None:
            progress.update(1)  # type: ignore[attr-defined]
    gls = sorted({str(worker["gl"]) for worker in workers if "gl" in worker})
    hosts = sorted({str(worker["host"]) for worker in workers if "host" in worker})
    header = header_lines("; ".join(gls) or "-", settings, scenes)
    header.append(f"workers: {pool.description} (hosts: {', '.join(hosts)}); each configuration timed alone on its worker "
                  "while the others drew theirs: the timings share the machine, for the throughput of sweeps "
                  "(bench without --workers times a scene's configurations in turn in one process); "
                  "accuracy figures as bench's")
    return PoolBench([rows[index] for index in sorted(rows)], header)
