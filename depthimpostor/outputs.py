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
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np
from PIL import Image

from .errors import OutputError
from .hdr import HDR_SUFFIXES, write_hdr

Writer = Callable[[IO[bytes]], None]


#: The image files a still frame is written as, by the file name's extension: each is written and
#: read back by tests/test_outputs.py. (Pillow registers more; some it cannot write an RGB image as
#: after all (.blp, .bufr, .grib, .h5, .xbm, ...), some it writes as another format whatever the
#: name says (.pbm, .pgm, .pfm become a binary PPM).)
IMAGE_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".bmp": "BMP", ".tif": "TIFF", ".tiff": "TIFF",
                 ".webp": "WEBP", ".ppm": "PPM", ".tga": "TGA"}
#: A temporary file's name is its destination's, hidden, with a random part and a suffix: the
#: destination's name is cut to this many characters there, so that the temporary's name is no
#: longer than the longest name a folder holds (NAME_MAX, 255 bytes on Linux) when the
#: destination's is.
_TEMPORARY_NAME_CHARACTERS = 100


def _stream(path: Path) -> bool:
    """A destination that is not a file to replace: a device or a pipe (`-o /dev/null`,
    `-o /dev/stdout`), written straight into. (Through a link, as /dev/stdout is: stat follows it
    where `Path.resolve` cannot, /proc/self/fd/1 naming "pipe:[...]".)"""
    try:
        mode = path.stat().st_mode
    except OSError:
        return False
    return not stat.S_ISREG(mode) and not stat.S_ISDIR(mode)


def is_stdout(path: Path) -> bool:
    """Is `path` this process's standard output (`-o /dev/stdout`, or the file stdout goes to)?
    Then what a command says goes to standard error, not into the image."""
    try:
        return os.path.samestat(path.stat(), os.fstat(1))
    except (OSError, ValueError):
        return False


def image_format(path: Path, option: str) -> str:
    """The PIL format a file name asks for (`.png` -> PNG; PNG into a device or a pipe);
    OutputError for one not in IMAGE_FORMATS."""
    if _stream(path) and not path.suffix:
        return "PNG"
    name = IMAGE_FORMATS.get(path.suffix.lower())
    if name is None:
        raise OutputError(f"{option} {path}: expected an image file name ending in one of "
                          f"{', '.join(IMAGE_FORMATS)}, got {path.suffix or 'no extension'!r}")
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


def _link_target(path: Path, option: str) -> Path:
    """Where writing `path` lands: itself, or the file a symbolic link (a chain of them) names,
    whose folder must exist: a dangling link's folder is not made (it is elsewhere, and the user
    asked for `path`)."""
    if not path.is_symlink():
        return path
    try:
        target = path.resolve(strict=False)
    except (OSError, RuntimeError) as error:  # a loop of links
        raise OutputError(f"{option} {path}: cannot follow the symbolic link: {error}") from None
    if not target.parent.is_dir():
        raise OutputError(f"{option} {path}: a symbolic link to {target}, whose folder does not exist; "
                          "make it, or name a file that is not a link")
    return target


def check_file(path: Path, option: str, image: bool = True, float_image: bool = False) -> Path:
    """Refuse, before any work, an output file that cannot be written: a name the system refuses
    (too long), a folder, an image format not in IMAGE_FORMATS (when `image`; `float_image`: or a
    float .exr or .hdr), a link into a folder that does not exist, a folder one cannot write in."""
    try:
        path.lstat()
    except FileNotFoundError:
        pass
    except OSError as error:  # File name too long, Not a directory, Permission denied, ...
        shown = str(path) if len(str(path)) <= 80 else f"{str(path)[:60]}...{str(path)[-16:]}"
        raise OutputError(f"{option} {shown}: cannot write this file: {error.strerror or error}") from None
    if path.is_dir():
        raise OutputError(f"{option} {path}: expected a file name, got an existing folder")
    if image and not (float_image and is_float_image(path)):
        image_format(path, option)
    if not _stream(path):
        _writable_folder(_link_target(path, option).parent, option, path)
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
        try:
            if _stream(path):  # a device or a pipe: nothing to replace, written straight in
                write(path)
                return path
            target = _link_target(path, "output")
            if target is path:  # a link's folder is not made (check_file)
                target.parent.mkdir(parents=True, exist_ok=True)
            prefix = f".{target.name[:_TEMPORARY_NAME_CHARACTERS]}."
            handle, name = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=target.parent)
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

