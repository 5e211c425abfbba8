"""A batch file (TOML) read into frames to render: `depthimpostor batch jobs.toml` (docs/batch.md).

```toml
manifest = "out/manifest.jsonl"     # optional (default: beside this file, jobs.manifest.jsonl)

[defaults]                           # optional: any job field, for every job
size = [320, 180]

[[jobs]]
name = "orbit"                       # unique; {job} in the output template
scene = "../scenes/default.toml"     # relative to this file
methods = ["depth", "raytrace"]      # or method = "depth"; {method}
algorithm = "optimized"
frames = 120                         # frame i at time start + i / fps, on camera_path ("orbit", "fixed")
fps = 30.0
start = 0.0
camera_path = "orbit"
# or: times = [0.0, 0.5, 1.0] and/or cameras = [{ eye = [...], target = [...] }, ...] (one frame each)
aov = ["reflector_id", "reflected_object_id"]
output = "out/{job}/{method}/{frame:04d}.png"
```

Every problem is one SceneError naming the file and the dotted field (`jobs[2].camera_path: ...`),
raised before any work. A job's *scene* is read by the worker that renders it, so that a bad scene
fails that job alone (reported in one line) while the others render.
"""

from __future__ import annotations

import itertools
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # as scene/loader.py
    import tomli as tomllib

from ..aov import aov_path, needs_reflection_data, parse_aovs
from ..constants import Algorithm, Method
from ..errors import SceneError
from ..scene.fields import (
    NAME, POSITIVE, SIZE, At, Bounds, Reader, Table, choice, integer, number, read_file_bytes, show,
)
from ..scene.loader import read_camera
from ..scene.model import IMPOSTOR_RESOLUTION, SAMPLES, Camera
from ..video import MAX_VIDEO_FRAMES, CameraPath, VideoSettings, orbit_view

if TYPE_CHECKING:  # the worker runs frames (worker.Task); it imports this module
    from .worker import FrameWorker

JOB_FIELDS = ("name", "scene", "method", "methods", "algorithm", "size", "impostor_resolution", "samples", "frames",
              "fps", "start", "camera_path", "times", "cameras", "aov", "output")
FILE_FIELDS = ("manifest", "defaults", "jobs")
#: The names an output template may use.
TEMPLATE_FIELDS = ("job", "method", "algorithm", "frame", "time")
MAX_BATCH_BYTES = 16 * 2**20

_METHOD = choice([m.option for m in Method])
_ALGORITHM = choice([a.name.lower() for a in Algorithm])
_STRINGS: Reader[list[str]] = Reader(
    "a list of strings", lambda v: list(v) if isinstance(v, list) and all(isinstance(x, str) for x in v) else None)
_TIMES: Reader[list[float] | None] = Reader(
    "a non-empty list of finite numbers (seconds)",
    lambda v: [float(x) for x in v] if isinstance(v, list) and v and all(number().parse(x) is not None for x in v) else None)


@dataclass(frozen=True)
class OrbitStep:
    """A frame's place on an orbit of the scene's camera (resolved by the worker, which reads the scene)."""

    frame: int
    frames: int


@dataclass(frozen=True)
class Frame:
    """One picture to render: everything a worker needs, as plain data (it travels to other machines)."""

    job: str
    index: int  # the frame's number in its job
    scene: str  # the scene file, absolute
    method: str
    algorithm: str
    overrides: tuple[tuple[str, Any], ...]  # Scene.with_overrides' arguments (size, impostor_resolution, ...)
    time: float
    camera: Camera | OrbitStep | None  # None: the scene's camera
    aovs: tuple[str, ...]
    output: str | None  # the colour file, absolute; None: returned to the caller (a video's frame)

    @property
    def outputs(self) -> list[Path]:
        """Every file this frame writes (complete when all of them exist: each is written atomically)."""
        if self.output is None:
            return []
        colour = Path(self.output)
        return [colour, aov_path(colour)] if self.aovs else [colour]

    def settings(self) -> dict[str, Any]:
        """The frame's settings as the manifest records them."""
        camera: object = None
        if isinstance(self.camera, Camera):
            camera = {"eye": list(self.camera.eye), "target": list(self.camera.target), "up": list(self.camera.up),
                      "fov_y": self.camera.fov_y}
        elif isinstance(self.camera, OrbitStep):
            camera = {"orbit": [self.camera.frame, self.camera.frames]}
        return {"job": self.job, "frame": self.index, "scene": self.scene, "method": self.method,
                "algorithm": self.algorithm, **dict(self.overrides), "time": self.time,
                "camera": camera, "aovs": list(self.aovs), "outputs": [str(p) for p in self.outputs]}

    def run(self, worker: FrameWorker) -> dict[str, Any]:
        """Draw and write this frame on `worker` (worker.Task)."""
        return worker.render(self)

    def renderer_key(self) -> tuple[object, ...]:
        """Frames with equal keys share one Renderer in a worker (the same scene and settings)."""
        return (self.scene, self.method, self.algorithm, self.overrides, needs_reflection_data(self.aovs))


@dataclass(frozen=True)
class Batch:
    source: str
    manifest: Path
    frames: list[Frame] = field(default_factory=list)


def load_batch(path: Path) -> Batch:
    source = os.fspath(path)
    try:
        data = tomllib.loads(read_file_bytes(Path(path), source, "a batch file (TOML)", MAX_BATCH_BYTES).decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise SceneError(source, "", f"expected a TOML batch file, got {error}") from None
    base = Path(path).resolve().parent
    top = Table(data, At(source, "", base), FILE_FIELDS)
    defaults = top.section("defaults", JOB_FIELDS).data
    manifest = top.opt("manifest", NAME, f"{Path(path).stem}.manifest.jsonl")
    frames: list[Frame] = []
    names: set[str] = set()
    for value, at in top.array("jobs", at_least=1):
        if not isinstance(value, Mapping):
            raise at.error(f"expected a table, got {show(value)}")
        job = Table({**defaults, **value}, at, JOB_FIELDS)
        name = job.req("name", NAME)
        if name in names:
            raise at.key("name").error(f"expected a name no other job has, got {show(name)} twice")
        names.add(name)
        frames += job_frames(job, name, base)
    _check_unique_outputs(frames, source)
    return Batch(source, base / manifest, frames)


def job_frames(job: Table, name: str, base: Path) -> list[Frame]:
    """Every frame of one [[jobs]] table (its defaults merged in)."""
    scene = str((base / job.req("scene", NAME)).resolve())
    methods = _methods(job)
    algorithm = job.opt("algorithm", _ALGORITHM, "optimized")
    named: list[str] = job.opt("aov", _STRINGS, [])
    aovs = parse_aovs(named, job.at.source, job.at.key("aov").path)
    template = job.req("output", NAME)
    views = _views(job)
    read: dict[str, Reader[Any]] = {"size": SIZE, "impostor_resolution": IMPOSTOR_RESOLUTION, "samples": SAMPLES}
    overrides = tuple((key, job.req(key, reader)) for key, reader in read.items() if key in job.data)
    frames = []
    for method, (index, (time, camera)) in itertools.product(methods, enumerate(views)):
        output = _output(job.at.key("output"), template, name, method, algorithm, index, time)
        frames.append(Frame(name, index, scene, method, algorithm, overrides, time, camera, aovs,
                            str((base / output).resolve())))
    return frames


def _methods(job: Table) -> list[str]:
    if "method" in job.data and "methods" in job.data:
        raise job.at.key("methods").error("expected method or methods, not both")
    if "methods" in job.data:
        methods = job.req("methods", _STRINGS)
        if not methods:
            raise job.at.key("methods").error("expected at least one method, got []")
        for k, method in enumerate(methods):
            job.at.key("methods").index(k).read(method, _METHOD)
        return list(dict.fromkeys(methods))
    return [job.opt("method", _METHOD, "depth")]


def _views(job: Table) -> list[tuple[float, Camera | OrbitStep | None]]:
    """Each frame's (time, camera): explicit times and/or cameras (one frame each; a single one
    serves every frame), or `frames` at `fps` from `start` along `camera_path`."""
    times = job.opt("times", _TIMES, None)
    cameras = None
    if "cameras" in job.data:
        value, at = job.data["cameras"], job.at.key("cameras")
        if not isinstance(value, list) or not value:
            raise at.error(f"expected a non-empty array of camera tables, got {show(value)}")
        cameras = [read_camera(Table(c, at.index(k), ("eye", "target", "up", "fov_y"))) for k, c in enumerate(value)]
    if times is not None or cameras is not None:
        for key in ("frames", "fps", "start", "camera_path"):
            if key in job.data:
                raise job.at.key(key).error("expected no value beside times or cameras (they give the frames)")
        count = max(len(times or ()), len(cameras or ()))
        for key, values in (("times", times), ("cameras", cameras)):
            if values is not None and len(values) not in (1, count):
                raise job.at.key(key).error(f"expected 1 or {count} values (as many as the other list), got {len(values)}")
        return [((times or [0.0])[k % len(times or [0.0])], (cameras or [None])[k % len(cameras or [None])])  # type: ignore[list-item]
                for k in range(count)]
    frames = job.opt("frames", integer(Bounds(1, MAX_VIDEO_FRAMES)), 1)
    fps = job.opt("fps", number(POSITIVE), 30.0)
    start = job.opt("start", number(), 0.0)
    path = CameraPath(job.opt("camera_path", choice([p.value for p in CameraPath]), CameraPath.FIXED.value))
    settings = VideoSettings(frames / fps, fps, path, start)
    return video_views(settings)


def video_views(settings: VideoSettings) -> list[tuple[float, Camera | OrbitStep | None]]:
    """Each frame's (time, camera) of a video (video.py: render_frames draws the same)."""
    orbit = settings.camera_path is CameraPath.ORBIT
    return [(settings.time(k), OrbitStep(k, settings.frames) if orbit else None) for k in range(settings.frames)]


def camera_for(frame_camera: Camera | OrbitStep | None, scene_camera: Camera) -> Camera:
    """The camera a frame is drawn through, given its scene's."""
    if isinstance(frame_camera, OrbitStep):  # as video.view_at: one turn over the frames
        return orbit_view(scene_camera, frame_camera.frame / frame_camera.frames)
    return frame_camera if frame_camera is not None else scene_camera


def _output(at: At, template: str, job: str, method: str, algorithm: str, frame: int, time: float) -> str:
    try:
        return template.format(job=job, method=method, algorithm=algorithm, frame=frame, time=time)
    except (KeyError, IndexError, ValueError) as error:
        raise at.error(f"expected a template of the fields {', '.join(TEMPLATE_FIELDS)} (such as "
                       f"\"out/{{job}}/{{frame:04d}}.png\"), got {show(template)} ({type(error).__name__}: {error})") from None


def _check_unique_outputs(frames: Sequence[Frame], source: str) -> None:
    seen: dict[str, Frame] = {}
    for frame in frames:
        for output in frame.outputs:
            other = seen.setdefault(str(output), frame)
            if other is not frame:
                raise SceneError(source, f"jobs.{frame.job}.output",
                                 f"expected a file name per frame (use {{frame}}, {{method}}, {{job}}), got {output} "
                                 f"for frame {other.index} of {other.job} and frame {frame.index} of {frame.job}")
