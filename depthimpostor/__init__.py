"""depthimpostor: specular reflections through depth-image impostors, intersected per pixel."""

from __future__ import annotations

__version__ = "0.1.0"
