"""Every limit a scene meets, checked before any work: at load, or in the plan when it depends on
the method or on what the mirrors can see. `render` builds its plan before any GL object, so the
`plan` command refuses exactly what `render` refuses (tests/test_limits.py walks them).

| limit | value | checked | why |
|---|---|---|---|
| a number in a scene file, and how far an object reaches from the origin | `MAX_COORDINATE` (1e18) | load: the field (`fields.py`); the object, from its position, scale, shape and orbit (`check_scene`; a model file's when the plan loads it) | float32 geometry squares distances |
| the scene file, and a glTF file read whole | a regular file (no FIFO, device or socket) of at most `MAX_SCENE_FILE_BYTES` (64 MiB, TOML; `loader.py`) or `MAX_FILE_BYTES` (2 GiB, glTF; `fields.py`) | load (`read_file_bytes`), before a byte is read | a FIFO blocked for ever, a link to /dev/zero read until the memory ran out |
| a glTF file's JSON | `gltf_file.MAX_JSON_OBJECTS` (2^18) objects and `MAX_JSON_VALUES` (2^22) values; nesting as deep as Python's JSON reader reads | load, counted in its bytes before it is parsed | a million nodes took 90 s and 1.3 GB; a file keeps its data in buffers |
| a glTF file's geometry | `gltf.MAX_PLACED_TRIANGLES` (2^24) triangles placed by its nodes, `gltf.MAX_DECODED_BYTES` (2 GiB) decoded; every accessor within its view, every view within its buffer | load, from the accessors' counts, before decoding (`gltf._decoded`) | nodes place a mesh again and again, accessors share bytes: a small file can claim billions of triangles |
| an image's size | `image_files.MAX_TEXELS` (2^26) a texture; `hdr.MAX_SIDE` (16384) a side and `hdr.MAX_PIXELS` (2^25) an environment; a scene's textures, glTF images and environment map together: the machine's available memory when it began loading (`image_files.scene_images_budget`: 4 bytes a texel kept, 8 while one decodes; the environment 12 and 28, `hdr.KEPT_PIXEL_BYTES`) | load, from the file's header, before decoding | a 10,000^2 texture took 67 s and 10 GB; ten 8192^2 textures, each within its limit, decoded 2.5 GB before the render's memory check |
| lights | `MAX_LIGHTS` (8) | load | the shading loops over a uniform array of that size |
| an image file's samples | 1- to 16-bit integers, or 32-bit floats in [0, 1] (linear); stored in 8 bits a channel | load (`image_files.py`'s table: other modes, and damaged files, refused) | textures are 8-bit sRGB on the GPU and in the truth (`SRGB_TABLE`) |
| glTF extensions | a file may require those `gltf_file.SUPPORTED_REQUIRED` names alone; what else it uses is drawn as if absent, `plan` listing it as ignored | load | a required extension changes what the data means: read without it, it would be misread |
| image textures | none of their own but their size (above): memory, `GL_MAX_TEXTURE_SIZE` (an image's side; the traced rays' atlas of them all), `GL_MAX_ARRAY_TEXTURE_LAYERS` (images grouped in one array), `GL_MAX_UNIFORM_BLOCK_SIZE` (their records: 64 bytes each, 256 at GL's least) | plan (`gpu/limits.py`, against the context) | they are sampled from `MATERIAL_ARRAYS` (4) texture arrays and one atlas (`texture_layout.py`) |
| distinct materials (diffuse, checker, metallic-roughness) | none: up to `MATERIAL_BLOCK_RECORDS` (146 of 112 bytes, GL 3.3's 16 KiB) in a uniform block, past it in a storage buffer, GL 4.3 (`gpu/limits.py`: a `GpuLimitError` on an older GL) | plan (`gpu/limits.py`, against the context) | every pass reads them from one table (`lib/shading.glsl`'s MaterialRecords), so that a material is written once; a draw of one object (the bakes) binds its own record of a copy a record every `DRAWN_MATERIAL_STRIDE` (256) bytes (`gpu/scene_blocks.DrawnMaterials`), a uniform block whatever the table's size |
| planes that are not mirrors (floors, walls) | none: the `MAX_ANALYTIC_PLANES` (8) largest are intersected exactly, the others drawn as meshes (`Scene.analytic_plane_indices`), which count as reflected objects below | not refused | the exact ones come from a uniform array of that size, and pay most where large (a floor around a mirror); `plan` says which |
| `render.max_bounces` | `MAX_BOUNCES` (4) | load | each bounce bakes an image per pair of mirrors |
| `render.max_bounces` > 1 with two or more mirrors or glass | the depth method alone | plan (`check_method`) | only the depth method bakes reflectors into each other's images |
| objects a mirror may show, and so its depth images | none: past `DEPTH_IMAGE_BLOCK_RECORDS` (64) a mirror's image records (and its lists of candidate images by ray, `methods/image_cells.py`) are a storage buffer, GL 4.3 (`BakedImages`: a `ContextError` on an older GL) | render | a uniform block holds 64 records within GL 3.3's guaranteed 16 KiB |
| the depth images' memory | `render.image_memory` (MiB, default 1024) | plan (`per_object_plan`): every image made smaller to fit, not refused | an atlas of a thousand images at 256^2 would take 2.6 GiB |
| reflected objects, traced methods (`raytrace`, `simplified`, `hybrid`) | none: each is an instance of its mesh in a two-level BVH, its record a few texels of the BVH's float texture (`methods/instances.py`) | render: the texture's rows against `GL_MAX_TEXTURE_SIZE` | a float texture of 1024-texel rows holds millions of records and nodes on any GL 3.3 |
| reflected triangles, `hybrid` | `MAX_NAMED_TRIANGLES` (2^24) | plan (`check_method`) | a float32 depth-image sample names a triangle |
| an object around a mirror's centre, or a light among the shadow casters | no frustum fits | plan | a pinhole image (depth image, cube map, shadow map) must see all of it |

Limits of the GL itself (texture sizes, memory) are the plan's figures against the context's.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

import numpy as np

from depthimpostor.constants import (
    MAX_COORDINATE,
    MAX_LIGHTS,
)
from depthimpostor.errors import SceneError
from depthimpostor.meshes import Mesh
from depthimpostor.scene.model import (
    BoxShape,
    CylinderShape,
    GltfShape,
    MeshShape,
    PlaneShape,
    Scene,
    Shape,
    SphereShape,
    TorusKnotShape,
    TorusShape,
)

if TYPE_CHECKING:  # the registry imports the GL side, which a scene file's loader does not need
    from depthimpostor.methods.registry import MethodSpec


def shape_reach(shape: Shape) -> float | None:
    """How far the shape reaches from its local origin; None for a model file, whose vertices
    are known once it is loaded (`check_model_reach`)."""
    if isinstance(shape, PlaneShape):
        return 0.5 * math.hypot(*shape.size)
    if isinstance(shape, BoxShape):
        return 0.5 * math.hypot(*shape.size)
    if isinstance(shape, SphereShape):
        return shape.radius
    if isinstance(shape, CylinderShape):
        return math.hypot(shape.radius, 0.5 * shape.height)
    if isinstance(shape, TorusShape):
        return shape.major + shape.minor
    if isinstance(shape, TorusKnotShape):
        return shape.radius + shape.tube  # the curve stays within `radius` of the origin (meshes.torus_knot)
    if isinstance(shape, GltfShape):  # read with the scene
        centre, radius = shape.mesh.bounding_sphere()
        return float(np.linalg.norm(centre)) + radius
    return None


def _check_reach(scene: Scene, index: int, local_reach: float) -> None:
    """Refuse objects[index] if a point of it, `local_reach` from its local origin, can come farther
    than MAX_COORDINATE from the world origin at any time of its animation (an orbit keeps its
    distance from its centre; a turn about its own position keeps it about that position)."""
    obj = scene.objects[index]
    stretch = max(obj.scale) * local_reach  # rotations keep lengths
    position = np.asarray(obj.position, np.float64)
    orbit = obj.animation.centre if obj.animation is not None else None
    centre = position if orbit is None else np.asarray(orbit, np.float64)
    with np.errstate(over="ignore", invalid="ignore"):  # a scene built in code may hold inf: refused below
        reach = float(np.linalg.norm(centre) + np.linalg.norm(position - centre)) + stretch
    if not reach <= MAX_COORDINATE:
        raise SceneError(scene.source, scene.object_label(index),
                         f"expected an object within {MAX_COORDINATE:g} of the origin (float32 geometry squares "
                         f"distances), got one reaching {reach:.3g} (its position, scale and shape together)")


def check_scene(scene: Scene) -> None:
    """The limits that the scene alone decides (the loader calls it, and so does the plan, for
    scenes built in code)."""
    if len(scene.lights) > MAX_LIGHTS:
        raise SceneError(scene.source, "lights", f"expected at most {MAX_LIGHTS} [[lights]] tables, got {len(scene.lights)}")
    _check_textured_shapes(scene)
    for index, obj in enumerate(scene.objects):
        local_reach = shape_reach(obj.shape)
        if local_reach is not None:
            _check_reach(scene, index, local_reach)


#: The shapes whose meshes carry UVs (meshes.py, textured_meshes.py); a glTF part has them where the
#: file gives TEXCOORD_0, a mesh file where it gives texture coordinates (OBJ's `vt`: known once it
#: is loaded, check_model_uvs). A torus knot (no natural image layout on its tube) has none.
TEXTURED_SHAPES = (PlaneShape, BoxShape, SphereShape, CylinderShape, TorusShape)


def _check_textured_shapes(scene: Scene) -> None:
    """A texture needs UVs: TEXTURED_SHAPES have them (a mesh file's are checked once it is loaded)."""
    for index, obj in enumerate(scene.objects):
        if scene.texture_slot(obj.material) < 0:
            continue
        if isinstance(obj.shape, TEXTURED_SHAPES + (MeshShape,)) \
                or (isinstance(obj.shape, GltfShape) and obj.shape.mesh.uvs is not None):
            continue
        name = re.sub(r"(?<!^)(?=[A-Z])", "_", type(obj.shape).__name__.removesuffix("Shape")).lower()
        kind = "a glTF part without TEXCOORD_0" if isinstance(obj.shape, GltfShape) else f"a {name} shape"
        raise SceneError(scene.source, scene.object_label(index, "material.texture"), "expected a shape with texture coordinates "
                         f"(a plane, box, sphere, cylinder, torus, or a glTF part with TEXCOORD_0), got {kind}, which has none")


def check_model_uvs(scene: Scene, index: int, model: Mesh) -> None:
    """A textured objects[index] whose model file, once loaded, has no texture coordinates."""
    obj = scene.objects[index]
    if scene.texture_slot(obj.material) >= 0 and model.uvs is None:
        path = obj.shape.path if isinstance(obj.shape, MeshShape) else obj.name
        raise SceneError(scene.source, scene.object_label(index, "material.texture"), "expected a shape with texture "
                         f"coordinates, got the mesh file {path}, which has none (no `vt` lines in an OBJ)")


def check_model_reach(scene: Scene, index: int, model: Mesh) -> None:
    """The reach check of objects[index], a model file's `model` once loaded (the plan calls it)."""
    centre, radius = model.bounding_sphere()
    _check_reach(scene, index, float(np.linalg.norm(centre)) + radius)


def check_method(scene: Scene, method: MethodSpec, reflectors: int, reflected_triangles: int) -> None:
    """The limits that depend on the method (methods/registry.py): `reflectors` mirrors and glass,
    that may show `reflected_triangles` triangles in all."""
    if scene.render.max_bounces > 1 and not method.bounces and reflectors > 1:
        raise SceneError(scene.source, "render.max_bounces",
                         f"expected 1 with --method {method.option}: mirrors and glass in one another are baked "
                         f"by the depth method alone, got {scene.render.max_bounces}")
    if method.triangle_limit is not None and reflectors and reflected_triangles > method.triangle_limit:
        raise SceneError(scene.source, "objects", f"expected at most {method.triangle_limit} reflected triangles "
                         f"with --method {method.option}, got {reflected_triangles}")
