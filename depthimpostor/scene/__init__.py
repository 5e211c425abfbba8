"""Scene files: TOML validated into frozen dataclasses, with errors that name the field.

A scene is plain nested data (the Mitsuba `load_dict` idea): a few optional sections, and arrays of
tables each chosen by its `type`. `load_scene` reads a file; every mistake in it is a `SceneError`
reading `FILE: dotted.path: expected ..., got ...`. The package is split by concern:

- `model`: the dataclasses (`Scene` and its parts, `Animation` among them) and their defaults;
- `fields`: small readers for one value each, and tables that reject unknown keys;
- `loader`: the format itself, as tables of shape, material, light and environment variants.
"""

from __future__ import annotations

from depthimpostor.scene.fields import Vec3
from depthimpostor.scene.loader import MODEL_PATH_VARIABLE, MODEL_SUFFIXES, load_scene, model_folders, parse_scene
from depthimpostor.scene.model import (
    AUTO_RESOLUTION,
    Animation,
    BoxShape,
    Camera,
    CheckerMaterial,
    CylinderShape,
    DiffuseMaterial,
    Environment,
    GlassMaterial,
    GltfOrigin,
    Light,
    Material,
    MeshShape,
    MirrorMaterial,
    PlaneShape,
    RenderSettings,
    Scene,
    SceneObject,
    Shape,
    SphereShape,
    TorusKnotShape,
    TorusShape,
)

__all__ = [
    "AUTO_RESOLUTION", "MODEL_PATH_VARIABLE", "MODEL_SUFFIXES", "Animation", "BoxShape", "Camera",
    "CheckerMaterial", "CylinderShape", "DiffuseMaterial", "Environment", "GlassMaterial", "GltfOrigin", "Light", "Material",
    "MeshShape", "MirrorMaterial", "PlaneShape", "RenderSettings", "Scene", "SceneObject", "Shape", "SphereShape",
    "TorusKnotShape", "TorusShape", "Vec3", "load_scene", "model_folders", "parse_scene",
]
