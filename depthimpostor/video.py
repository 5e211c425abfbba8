"""Videos of a scene (`depthimpostor render SCENE --video out.mp4 --duration S --fps N`).

Frame i shows scene time `start + i / fps` (the animation plays in real time) through a camera on
a path: `orbit` turns the scene camera's eye once about the world up axis through its target over
the duration (its distance and height kept; the orbit math is the viewer's, navigation.py), and
`fixed` keeps the scene's camera. By default a scene that animates keeps its camera (the animation
is what the video is for, and the scene's camera was placed to frame it) and a still scene orbits
(a fixed camera would give one frame over and over).

The frames are drawn one after the other by one `Renderer` (only what moved is baked again) and
read through the scene's display transform (`read_color`), as `render -o frame.png` writes them.
MP4 (H.264, yuv420p, which every player reads) is encoded by ffmpeg through imageio (the
imageio-ffmpeg wheel carries its own ffmpeg binary) as the frames come; GIF by Pillow's frame
encoder, each frame with its own 256-colour palette, as the frames come too (Pillow's own
multi-frame save holds every frame until the end). Either is written atomically (outputs.py): a
failure, Ctrl-C or a SIGTERM leaves no half video and no temporary file. A video has at most
MAX_VIDEO_FRAMES frames, checked before any work.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np
from PIL import GifImagePlugin, Image
from tqdm import tqdm

from .errors import OutputError, SceneError
from .interrupts import raise_pending
from .outputs import Outputs, check_file
from .renderer import Renderer
from .scene import Scene
from .scene.model import Camera
from .viewer.navigation import Navigation

MP4, GIF = ".mp4", ".gif"
VIDEO_SUFFIXES = (MP4, GIF)
#: A GIF's frame times are whole centiseconds, in 16 bits: a frame shows for at most 655.35 s.
GIF_TICKS_PER_SECOND = 100
GIF_MAX_TICKS = 2**16 - 1
#: The most frames a video may have (55 minutes at 30 frames/s): a typo such as `--fps 1e9` is
#: refused at once instead of rendering for years.
MAX_VIDEO_FRAMES = 100_000
#: ffmpeg's quality scale (0 to 10) for H.264; 8 keeps the checkers' edges crisp at a few
#: hundred kB per second of 960x540.
MP4_QUALITY = 8


class CameraPath(Enum):
    ORBIT = "orbit"
    FIXED = "fixed"

    @staticmethod
    def default_for(scene: Scene) -> CameraPath:
        """Fixed for a scene that animates, an orbit for a still one (see the module's docstring)."""
        return CameraPath.FIXED if scene.animated else CameraPath.ORBIT


@dataclass(frozen=True)
class VideoSettings:
    duration: float  # seconds of scene time (and of video)
    fps: float
    camera_path: CameraPath
    start: float = 0.0  # scene time of the first frame

    @property
    def frames(self) -> int:
        return round(self.duration * self.fps)

    def time(self, frame: int) -> float:
        return self.start + frame / self.fps


def check_video_settings(settings: VideoSettings, size: tuple[int, int], path: Path) -> None:
    """Refuse, before any work, settings that give no video: a duration or frame rate that is not
    positive and finite, fewer than one frame, an odd frame size for MP4 (yuv420p halves the
    colour's resolution, so ffmpeg's H.264 needs even sides)."""
    for option, value in (("--duration", settings.duration), ("--fps", settings.fps)):
        if not (math.isfinite(value) and value > 0.0):
            raise SceneError("command line", option, f"expected a positive number, got {value:g}")
    count = settings.duration * settings.fps  # before `frames`: 1e308 x 1e308 is no integer
    if count >= MAX_VIDEO_FRAMES + 0.5:
        raise SceneError("command line", "--duration", f"expected at most {MAX_VIDEO_FRAMES:,} frames: "
                         f"{settings.duration:g} s at {settings.fps:g} frames/s is {count:,.6g} frames")
    if settings.frames < 1:
        raise SceneError("command line", "--duration", f"expected at least one frame: {settings.duration:g} s at "
                         f"{settings.fps:g} frames/s is {settings.duration * settings.fps:.3g} frames")
    if path.suffix.lower() == GIF and math.ceil(GIF_TICKS_PER_SECOND / settings.fps) > GIF_MAX_TICKS:
        least = math.ceil(GIF_TICKS_PER_SECOND / GIF_MAX_TICKS * 1e8) / 1e8  # shown rounded up: taken itself
        raise SceneError("command line", "--fps", f"expected at least {least:g} "
                         f"frames/s for a GIF (a GIF frame shows for at most {GIF_MAX_TICKS / 100:g} s), "
                         f"got {settings.fps:g}")
    if path.suffix.lower() == MP4 and (size[0] % 2 or size[1] % 2):
        raise SceneError("command line", "--size", f"expected an even width and height for an MP4 video (H.264 "
                         f"in yuv420p), got {size[0]}x{size[1]}: make it {size[0] + size[0] % 2}x"
                         f"{size[1] + size[1] % 2}, or write a .gif")


def check_video_file(path: Path, option: str = "--video") -> Path:
    """Refuse, before any work, a video file name of an unknown kind or one that cannot be written."""
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise OutputError(f"{option} {path}: expected a video file name ending in {' or '.join(VIDEO_SUFFIXES)}, "
                          f"got {path.suffix or 'no extension'!r}")
    return check_file(path, option, image=False)


def orbit_view(view: Camera, turn: float) -> Camera:
    """`view` with its eye turned `turn` full turns about the world up axis through its target: the
    same distance, the same height. (The radius only bounds zooms, which an orbit does not make.)"""
    navigation = Navigation(view, scene_radius=1.0)
    navigation.turn(360.0 * turn, 0.0)
    return navigation.view()


def view_at(view: Camera, settings: VideoSettings, frame: int) -> Camera:
    """The camera of `frame`: one full orbit over the video's frames (the last frame one step short
    of the first, so that a looping video turns evenly), or `view` itself."""
    if settings.camera_path is CameraPath.FIXED:
        return view
    return orbit_view(view, frame / settings.frames)


def render_frames(renderer: Renderer, settings: VideoSettings) -> Iterator[np.ndarray]:
    """Each frame of the video as (height, width, 3) uint8, through the scene's display transform."""
    home = renderer.view
    for frame in range(settings.frames):
        raise_pending()  # a Ctrl-C that landed in a finalizer during the last frame
        renderer.set_time(settings.time(frame))
        renderer.look_at(view_at(home, settings, frame))
        renderer.render()
        yield renderer.read_color()


def gif_duration(frame: int, fps: float) -> int:
    """The GIF frame's time in milliseconds (whole centiseconds, as the format stores them),
    rounded where it ends so that the video keeps its frame rate on average (30 frames/s alternates
    30 and 40 ms instead of running 10% fast at 30 ms each)."""
    start = 0 if frame == 0 else round(GIF_TICKS_PER_SECOND * frame / fps)
    end = round(GIF_TICKS_PER_SECOND * (frame + 1) / fps)
    # A frame of no time would be dropped by players; at most 100 frames/s shows.
    return max(end - start, 1) * (1000 // GIF_TICKS_PER_SECOND)


def gif_durations(frames: int, fps: float) -> list[int]:
    """Each of `frames` GIF frames' times in milliseconds (gif_duration)."""
    return [gif_duration(frame, fps) for frame in range(frames)]


def _write_gif(name: Path, frames: Iterable[np.ndarray], fps: float) -> None:
    """Each frame written as it comes (memory does not grow with the video), with its own palette
    (median cut over its own colours: an orbit sees other colours as it turns); a frame identical
    to the one before is written once, for their time together (as Pillow's own save does)."""
    pending: tuple[Image.Image, int] | None = None  # a frame not yet written, and its time
    with name.open("wb") as file:
        def put(picture: Image.Image, milliseconds: int, first: bool) -> None:
            if first:  # the file's header and the loop block (the global palette is the first frame's)
                header, _ = GifImagePlugin.getheader(picture, info={"loop": 0, "duration": milliseconds})
                file.writelines(header)
            file.writelines(GifImagePlugin.getdata(picture, duration=milliseconds, include_color_table=True))

        written = 0
        for index, frame in enumerate(frames):
            picture = Image.fromarray(frame).quantize(colors=256, method=Image.Quantize.MEDIANCUT)
            milliseconds = gif_duration(index, fps)
            if pending is not None and _same_picture(pending[0], picture) and pending[1] + milliseconds <= \
                    GIF_MAX_TICKS * (1000 // GIF_TICKS_PER_SECOND):
                pending = (pending[0], pending[1] + milliseconds)
                continue
            if pending is not None:
                put(*pending, first=written == 0)
                written += 1
            pending = (picture, milliseconds)
        if pending is not None:
            put(*pending, first=written == 0)
        file.write(b";")  # the trailer


def _same_picture(a: Image.Image, b: Image.Image) -> bool:
    return a.tobytes() == b.tobytes() and a.getpalette() == b.getpalette()


def _write_mp4(name: Path, frames: Iterable[np.ndarray], fps: float) -> None:
    import imageio.v2 as imageio  # the [video] extra's: only an MP4 needs it

    # macro_block_size 1: frames of the size asked for (ffmpeg would otherwise scale them to
    # multiples of 16); the size was checked to be even (check_video_settings).
    writer = imageio.get_writer(name, format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=MP4_QUALITY,
                                pixelformat="yuv420p", macro_block_size=1, ffmpeg_log_level="error")
    try:
        for frame in frames:
            writer.append_data(frame)
    except BaseException:
        # imageio's writer leaves ffmpeg running when its block fails (a frame that could not be
        # drawn); ffmpeg must be done with the temporary file before Outputs removes it, or it
        # could open (and so make again) the file afterwards, as it did under load.
        with contextlib.suppress(Exception):
            writer.close()
        raise
    writer.close()


def write_video(path: Path, frames: Iterable[np.ndarray], fps: float) -> Path:
    """`frames` as the video `path` names (.mp4 or .gif), written atomically."""
    suffix = path.suffix.lower()
    with Outputs() as out:
        if suffix == GIF:
            return out.write_named(path, lambda name: _write_gif(name, frames, fps), suffix=GIF)
        return out.write_named(path, lambda name: _write_mp4(name, frames, fps), suffix=MP4)


def render_video(renderer: Renderer, path: Path, settings: VideoSettings, progress: bool = True) -> Path:
    """Render `settings.frames` frames with `renderer` into the video `path`, with a progress bar
    (on standard error) unless `progress` is False."""
    frames = render_frames(renderer, settings)
    with tqdm(frames, total=settings.frames, unit="frame", desc=path.name, disable=not progress) as shown:
        return write_video(path, shown, settings.fps)
