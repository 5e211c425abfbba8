"""One batch worker: a GL context and one Renderer per scene and settings for its lifetime, frames
rendered and written one at a time. The same class renders in this process (`FrameWorker`, the
serial path and the tests' reference) and in a Ray actor (run.py wraps it), so that a batch draws
exactly what a serial run draws.

A frame whose files are all in place is not drawn again (`found`): each file is written atomically
(outputs.py), so a file that exists is whole. That is what makes a rerun resume, and what keeps a
frame retried after its worker was killed between writing and reporting from being drawn twice.
"""

from __future__ import annotations

import contextlib
import os
import socket
import time
from collections import OrderedDict
from pathlib import Path
from typing import Any, Protocol

import moderngl
import numpy as np

from ..aov import aov_path, compute_aovs, needs_reflection_data, write_aovs
from ..constants import Algorithm, Method
from ..errors import DepthImpostorError
from ..gpu.context import Backend, create_context, describe
from ..gpu.limits import limit_memory
from ..outputs import Outputs, is_float_image
from ..renderer import Renderer
from ..scene import Scene, load_scene
from .jobs import Frame, camera_for

#: Renderers (and scenes) a worker keeps, the most recently used: a batch's frames come job by job,
#: so a few cover the jobs in flight, and a dataset of thousands of scenes does not hold the GL
#: memory of every one.
KEPT_RENDERERS = 4
#: A manifest record's status: drawn and written now, its files found complete, or failed (with `error`).
RENDERED, FOUND, FAILED = "rendered", "found", "failed"


class Task(Protocol):
    """What a worker runs: a frame (jobs.Frame), or a configuration of `bench` (bench_tasks.py).
    Plain data, sent to the worker; `run` never raises: a failure is a record with `error`."""

    def settings(self) -> dict[str, Any]:
        """What the task is, as its record (the manifest's line) names it."""
        ...

    def run(self, worker: FrameWorker) -> dict[str, Any]:
        """Do the task with this worker's context and kept objects; its record."""
        ...


def one_line(error: BaseException) -> str:
    """An error as one line: our errors say what and where; another names its type."""
    text = str(error) if isinstance(error, DepthImpostorError) else f"{type(error).__name__}: {error}"
    return " ".join(text.split())


def complete(frame: Frame) -> bool:
    return bool(frame.outputs) and all(path.is_file() for path in frame.outputs)


class FrameWorker:
    """Renders frames (jobs.Frame) with one context, keeping a Renderer per (scene, settings)."""

    def __init__(self, backend: Backend | None = None, device: int | None = None, max_memory: int | None = None) -> None:
        self.backend, self.device, self.max_memory = backend, device, max_memory
        self._ctx: moderngl.Context | None = None
        self._renderers: OrderedDict[tuple[object, ...], Renderer] = OrderedDict()
        self._scenes: OrderedDict[str, Scene] = OrderedDict()
        self._kept: OrderedDict[tuple[object, ...], object] = OrderedDict()

    @property
    def ctx(self) -> moderngl.Context:
        if self._ctx is None:
            self._ctx = create_context(self.backend, self.device)
            limit_memory(self._ctx, self.max_memory)
        return self._ctx

    def identity(self) -> dict[str, Any]:
        """Where a frame was drawn: the manifest's `worker` (the GL and EGL device once a context is made)."""
        where: dict[str, Any] = {"host": socket.gethostname(), "pid": os.getpid()}
        if self._ctx is not None:
            where |= {"gl": describe(self._ctx), **({"device": self.device} if self.device is not None else {})}
        return where

    @property
    def kept(self) -> int:
        """Renderers this worker keeps now (at most KEPT_RENDERERS)."""
        return len(self._renderers)

    def run(self, task: Task) -> dict[str, Any]:
        """The task's record (a frame's: `render`)."""
        return task.run(self)

    def render(self, frame: Frame) -> dict[str, Any]:
        """Draw and write `frame` (or return its colour as `image` where it has no output file);
        its manifest record. Never raises for a frame that cannot be drawn: the record says why."""
        record: dict[str, Any] = frame.settings()
        if complete(frame):
            return {**record, "worker": self.identity(), "status": FOUND}
        started = time.perf_counter()
        try:
            renderer, made = self._renderer(frame)
            ready = time.perf_counter()
            result = self._draw(renderer, frame)
        except Exception as error:  # one frame's failure (a bad scene, a GL limit) is reported, the worker goes on
            self._forget(frame)
            return {**record, "worker": self.identity(), "status": FAILED, "error": one_line(error)}
        seconds = {"setup": round(ready - started, 6) if made else 0.0, **result.pop("seconds")}
        return {**record, "worker": self.identity(), "status": RENDERED, "seconds": seconds, **result}

    def _renderer(self, frame: Frame) -> tuple[Renderer, bool]:
        key = frame.renderer_key()
        if key in self._renderers:
            self._renderers.move_to_end(key)
            return self._renderers[key], False
        scene = self.scene(frame.scene).with_overrides(**dict(frame.overrides))
        renderer = Renderer(self.ctx, scene, Algorithm[frame.algorithm.upper()], method=Method.from_option(frame.method),
                            reflection_data=needs_reflection_data(frame.aovs))
        self._renderers[key] = renderer
        while len(self._renderers) > KEPT_RENDERERS:  # the least recently used goes, with its GL memory
            _, oldest = self._renderers.popitem(last=False)
            oldest.release()
        return renderer, True

    def scene(self, path: str) -> Scene:
        """The scene file at `path`, read once while it is among the most recently used."""
        if path in self._scenes:
            self._scenes.move_to_end(path)
        else:
            self._scenes[path] = load_scene(path)
            while len(self._scenes) > KEPT_RENDERERS:
                self._scenes.popitem(last=False)
        return self._scenes[path]

    def recall(self, key: tuple[object, ...]) -> object | None:
        """What was kept for `key` (a bench configuration's truth, traced once per scene on this
        worker as the serial bench traces it once per scene), None if nothing or let go."""
        if key in self._kept:
            self._kept.move_to_end(key)
        return self._kept.get(key)

    def keep(self, key: tuple[object, ...], value: object) -> None:
        """Keep `value` for `key`, among the KEPT_RENDERERS most recently used."""
        self._kept[key] = value
        self._kept.move_to_end(key)
        while len(self._kept) > KEPT_RENDERERS:
            self._kept.popitem(last=False)

    def _forget(self, frame: Frame) -> None:
        """A renderer that failed mid-frame is made anew for the next frame (its state is unknown)."""
        renderer = self._renderers.pop(frame.renderer_key(), None)
        if renderer is not None:
            # Releasing what failed may fail too; the record says the first error.
            with contextlib.suppress(Exception):
                renderer.release()

    def _draw(self, renderer: Renderer, frame: Frame) -> dict[str, Any]:
        """As video.render_frames draws a frame: the time, then the camera, then the frame."""
        started = time.perf_counter()
        renderer.set_time(frame.time)
        renderer.look_at(camera_for(frame.camera, renderer.scene.camera))
        bakes = len(renderer.stats.bake_seconds)
        stats = renderer.render()
        drawn = time.perf_counter()
        output = frame.output
        linear = output is not None and is_float_image(Path(output))
        image = renderer.read_color_float() if linear else renderer.read_color()
        aovs, figures = compute_aovs(renderer, frame.aovs) if frame.aovs else ({}, None)
        colour = renderer.read_color_float() if frame.aovs else None
        computed = time.perf_counter()
        result: dict[str, Any] = {"figures": {
            "draw_ms": round(1000 * stats.draw_seconds[-1], 3),
            "bake_ms": round(1000 * sum(stats.bake_seconds[bakes:]), 3),
            "stand_in": renderer.graph.stand_in.describe() if renderer.graph.stand_in is not None else None,
            "stand_in_bytes": renderer.graph.stand_in.bytes if renderer.graph.stand_in is not None else 0,
            **({"truth": figures} if figures is not None else {}),
        }}
        if output is None:
            result["image"] = np.ascontiguousarray(image)
        else:
            with Outputs() as out:  # the colour and its AOVs in place together
                if linear:
                    out.float_image(Path(output), image)
                else:
                    out.image(Path(output), image)
                if colour is not None:
                    write_aovs(out, aov_path(Path(output)), colour, aovs)
        result["seconds"] = {"draw": round(drawn - started, 6), "aov": round(computed - drawn, 6),
                             "write": round(time.perf_counter() - computed, 6)}
        return result

    def release(self) -> None:
        for renderer in self._renderers.values():
            renderer.release()
        self._renderers.clear()
        self._kept.clear()
        if self._ctx is not None:
            self._ctx.release()
            self._ctx = None
