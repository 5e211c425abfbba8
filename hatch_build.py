"""Puts shaders/ and scenes/ inside the package of a wheel, but not of an editable install.

Hatch copies force-included files into site-packages even for an editable install, where they
would make a bare `depthimpostor/` folder that shadows the checkout's package from any other
working directory (pypa/hatch#1627). The editable install reads them from the checkout instead
(depthimpostor/resources.py).
"""

from __future__ import annotations

from typing import Any

from hatchling.builders.hooks.plugin.interface import BuildHookInterface


class CustomBuildHook(BuildHookInterface):  # type: ignore[misc]
    def initialize(self, version: str, build_data: dict[str, Any]) -> None:
        if version == "editable":
            return
        build_data["force_include"]["shaders"] = "depthimpostor/shaders"
        build_data["force_include"]["scenes"] = "depthimpostor/scenes"
