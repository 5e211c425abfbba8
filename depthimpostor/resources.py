"""Where the GLSL sources and the bundled scene files are.

In a source checkout (or an editable install) they sit beside the package at the top of the
repository; a wheel carries them inside the package (see pyproject.toml, force-include).
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def _data_dir(name: str) -> Path:
    for candidate in (_PACKAGE_DIR / name, _PACKAGE_DIR.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"depthimpostor is installed without its {name}/ folder (looked beside {_PACKAGE_DIR})")


def shaders_dir() -> Path:
    return _data_dir("shaders")


def scenes_dir() -> Path:
    return _data_dir("scenes")


def default_scene_path() -> Path:
    return scenes_dir() / "default.toml"
