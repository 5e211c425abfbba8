"""The interactive viewer (`depthimpostor view`): a glfw window on the same renderer as `render`."""

from .app import ViewerOptions, run_viewer

__all__ = ["ViewerOptions", "run_viewer"]
