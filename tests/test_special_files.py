"""A scene path that is not a regular file is refused in one line, at once: a FIFO blocked for
ever (open waits for a writer), a link to /dev/zero read until the memory ran out; a file larger
than a scene can be is refused by its size, or as it is read (scene/fields.py: read_file_bytes)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import PROJECT_ROOT
from depthimpostor.errors import SceneError
from depthimpostor.scene import load_scene
from depthimpostor.scene.fields import read_file_bytes


@pytest.mark.parametrize("name", ["s.toml", "s.glb"])
def test_a_fifo_is_refused_at_once(tmp_path: Path, name: str) -> None:
    fifo = tmp_path / name
    os.mkfifo(fifo)
    env = {**os.environ, "PYTHONPATH": str(PROJECT_ROOT)}
    # In a child with a timeout: without the fix, it waits for a writer for ever.
    done = subprocess.run([sys.executable, "-m", "depthimpostor", "plan", str(fifo)], env=env, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2 and done.stdout == ""
    kind = "a scene file" if name.endswith(".toml") else "a glTF file"
    assert done.stderr == f"depthimpostor: {fifo}: expected {kind} (a regular file), got a FIFO (named pipe)\n"


@pytest.mark.parametrize("name", ["z.toml", "z.glb"])
def test_a_link_to_a_device_is_refused(tmp_path: Path, name: str) -> None:
    link = tmp_path / name
    link.symlink_to("/dev/zero")
    with pytest.raises(SceneError, match=r"z\.(toml|glb): expected a (scene|glTF) file \(a regular file\), got a "
                                         "character device$"):
        load_scene(link)


def test_a_file_larger_than_the_limit_is_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.toml"
    with big.open("wb") as file:  # sparse: 65 MiB of nothing on the disk
        file.truncate(65 * 2**20)
    with pytest.raises(SceneError, match=r"big\.toml: expected a scene file of at most 64 MiB, got one of 65\.0 MiB$"):
        load_scene(big)
    # A file whose size reads 0 (in /proc) is still read no further than the limit.
    assert os.stat("/proc/self/status").st_size == 0
    with pytest.raises(SceneError, match="expected a status of at most 1.52588e-05 MiB, got more$"):
        read_file_bytes(Path("/proc/self/status"), "status", "a status", limit=16)
    assert read_file_bytes(Path("/proc/self/status"), "status", "a status").startswith(b"Name:")


def test_a_directory_is_still_named_as_one(tmp_path: Path) -> None:
    folder = tmp_path / "d.toml"
    folder.mkdir()
    with pytest.raises(SceneError, match=r"d\.toml: expected a scene file, got a directory$"):
        load_scene(folder)
