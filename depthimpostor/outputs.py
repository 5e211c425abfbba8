"""Every file the package writes goes through here: checked before the work, written atomically.

A destination is checked before any rendering (`check_file`, `check_folder`): a folder named as a
file, an image format PIL cannot write, a folder that cannot be made or written to are refused in
one line naming the option. Each file is then written to a temporary file in its own folder and
moved over the destination with `os.replace`, so that a reader never sees a half-written file and
two writers to one path leave one whole file (not one file with the tail of the other). `Outputs`
does this for a set of files (a report, a benchmark's results): all are written to temporary files
first and moved into place only once every one has been written, so that a failure (a full disk)
leaves none of them, not half a report.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np
from PIL import Image

from .errors import OutputError
from .hdr import HDR_SUFFIXES, write_hdr

Writer = Callable[[IO[bytes]], None]


def _stream(path: Path) -> bool:
    """A destination that is not a file to replace: a device or a pipe (`-o /dev/null`,
    `-o /dev/stdout`), written straight into."""
    return path.exists() and not path.is_file() and not path.is_dir()


def image_format(path: Path, option: str) -> str:
    """The PIL format a file name asks for (`.png` -> PNG; PNG into a device or a pipe);
    OutputError for one Pillow cannot write."""
    if _stream(path) and not path.suffix:
        return "PNG"
    formats = Image.registered_extensions()
    writable = sorted(ext for ext, name in formats.items() if name in Image.SAVE)
    name = formats.get(path.suffix.lower())
    if name is None or name not in Image.SAVE:
        raise OutputError(f"{option} {path}: expected an image file name ending in one of .png, .jpg, .bmp, .tif "
                          f"(any of {len(writable)} that Pillow writes), got {path.suffix or 'no extension'!r}")
    return name


def _writable_folder(folder: Path, option: str, shown: Path) -> None:
    """Prove a file can be created in `folder`: make it (and its parents), create a file, and take
    away again what was made, so that a run refused later leaves no empty folder behind. (Trying is
    the only sure test: root may write where the permission bits say not, and nobody in /proc.)"""
    missing = [parent for parent in (folder, *folder.parents) if not parent.exists()]
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as error:
        raise OutputError(f"{option} {shown}: cannot write in {folder}: {error.strerror or error}") from None
    finally:
        for made in missing:  # deepest first
            if made.is_dir():
                made.rmdir()


def is_float_image(path: Path) -> bool:
    """Does the name ask for a float image (linear, unclamped: .exr or .hdr; hdr.py writes them)?"""
    return path.suffix.lower() in HDR_SUFFIXES


def check_file(path: Path, option: str, image: bool = True, float_image: bool = False) -> Path:
    """Refuse, before any work, an output file that cannot be written: a folder, an image format
    Pillow cannot write (when `image`; `float_image`: or a float .exr or .hdr), a folder one cannot
    write in."""
    if path.is_dir():
        raise OutputError(f"{option} {path}: expected a file name, got an existing folder")
    if image and not (float_image and is_float_image(path)):
        image_format(path, option)
    if not _stream(path):
        _writable_folder(path.parent, option, path)
    return path


def check_folder(path: Path, option: str) -> Path:
    """Refuse, before any work, an output folder that is a file or cannot be made or written in."""
    if path.exists() and not path.is_dir():
        raise OutputError(f"{option} {path}: expected a folder for the output files, got an existing file")
    _writable_folder(path, option, path)
    return path


def _image_writer(image: np.ndarray | Image.Image, path: Path) -> Writer:
    picture = image if isinstance(image, Image.Image) else Image.fromarray(image)
    name = image_format(path, "output")
    return lambda file: picture.save(file, format=name)


def _float_image_writer(image: np.ndarray, path: Path) -> Writer:
    return lambda file: write_hdr(file, image, path.suffix)


def _text_writer(text: str) -> Writer:
    data = text.encode("utf-8")

    def write(file: IO[bytes]) -> None:
        file.write(data)
    return write


class Outputs:
    """Files written together: each to a temporary file beside its destination, all moved into
    place when the block ends without an error, none otherwise.

        with Outputs() as out:
            out.image(folder / "render.png", pixels)
            out.text(folder / "report.json", text)
    """

    def __init__(self) -> None:
        self._pending: list[tuple[Path, Path, bool]] = []  # (temporary, destination, exclusive)

    def write(self, path: Path, writer: Writer, exclusive: bool = False) -> Path:
        """Write through `writer` (given a binary file) to a temporary file for `path`; returns
        `path`. An `exclusive` file never replaces one: its commit raises FileExistsError if
        `path` exists. A symbolic link's target is what gets replaced, as open() would write it."""
        def write(name: Path) -> None:
            with name.open("wb") as file:
                writer(file)
        return self.write_named(path, write, exclusive)

    def write_named(self, path: Path, write: Callable[[Path], None], exclusive: bool = False,
                    suffix: str = ".tmp") -> Path:
        """Like `write`, for a writer that opens the file itself by its name (ffmpeg): `write` is
        given the temporary file's name, which ends in `suffix` (ffmpeg reads the format there)."""
        path = Path(path)
        target = path.resolve() if path.is_symlink() else path
        try:
            if _stream(target):  # a device or a pipe: nothing to replace, written straight in
                write(target)
                return path
            target.parent.mkdir(parents=True, exist_ok=True)
            handle, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=target.parent)
            os.close(handle)
            self._pending.append((Path(name), target, exclusive))
            write(Path(name))
            with open(name, "rb") as written:  # on the disk before it is moved into place
                os.fsync(written.fileno())
        except OSError as error:  # a full disk, a file-size limit, an I/O error
            raise OutputError(f"cannot write {path}: {error.strerror or error}") from None
        return path

    def image(self, path: Path, image: np.ndarray | Image.Image, exclusive: bool = False) -> Path:
        return self.write(path, _image_writer(image, Path(path)), exclusive)

    def float_image(self, path: Path, image: np.ndarray) -> Path:
        """A (height, width, 3) float image as .exr or .hdr (by `path`'s suffix)."""
        return self.write(path, _float_image_writer(image, Path(path)))

    def text(self, path: Path, text: str) -> Path:
        return self.write(path, _text_writer(text))

    def commit(self) -> None:
        umask = os.umask(0)
        os.umask(umask)
        for temporary, path, exclusive in self._pending:
            try:
                # Keep the permissions a plain open() would have given (mkstemp makes 0600).
                os.chmod(temporary, 0o666 & ~umask)
                if exclusive:  # a hard link is made only where no file is: atomic and never overwrites
                    os.link(temporary, path)
                    temporary.unlink()
                else:
                    os.replace(temporary, path)
            except FileExistsError:
                raise
            except OSError as error:
                raise OutputError(f"cannot write {path}: {error.strerror or error}") from None
        self._pending.clear()

    def discard(self) -> None:
        for temporary, _, _ in self._pending:
            temporary.unlink(missing_ok=True)
        self._pending.clear()

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, kind: type[BaseException] | None, *args: object) -> None:
        if kind is None:
            try:
                self.commit()
            finally:
                self.discard()
        else:
            self.discard()


def write_image(path: Path, image: np.ndarray | Image.Image, exclusive: bool = False) -> Path:
    """One image, atomically (`exclusive`: never over an existing file, FileExistsError instead)."""
    with Outputs() as out:
        return out.image(path, image, exclusive)


def write_float_image(path: Path, image: np.ndarray) -> Path:
    """One float image (.exr or .hdr), atomically."""
    with Outputs() as out:
        return out.float_image(path, image)


def write_text(path: Path, text: str) -> Path:
    """One text file (UTF-8), atomically."""
    with Outputs() as out:
        return out.text(path, text)

