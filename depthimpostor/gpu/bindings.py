"""Every texture unit, uniform-block binding, storage-buffer binding and image unit the renderer's
programs use, in one table (three.js's allocateTextureUnit, in its static form).

The mirror shader samples most of these at once (the atlas, its pyramid, shadow maps, glass
interiors, the BVH), so texture units are unique across the whole renderer, not per pass: a pass
that binds its textures never unbinds another's. `@unique` makes a duplicate an import error.
The compute pass's storage and image bindings are written into its GLSL as defines
(glsl_bindings), so that they are not repeated by hand in GLSL.
"""

from __future__ import annotations

from enum import IntEnum, unique


@unique
class TextureUnit(IntEnum):
    IMPOSTOR_COLOR = 0  # the baked images' colours (methods/impostors.py)
    IMPOSTOR_DEPTH = 1  # their depth layers
    PYRAMID = 2  # the hierarchical traversal's min/max depth pyramid (methods/pyramid.py)
    IMPOSTOR_BACK_COLOR = 3  # the back layer's colours
    IMPOSTOR_BEYOND = 4  # where a second solid run begins (the hybrid method's)
    SHADOW_MAPS = 5  # every light's shadow map (passes/shadows.py)
    GLASS_FRONT = 6  # a glass object's interior image: front faces (passes/glass.py)
    GLASS_BACK = 7  # and back faces
    BVH_NODES = 8  # the traced methods' BVH, both levels, and their instance records (methods/triangles.py)
    BVH_TRIANGLES = 9
    BVH_PLACES = 10  # the hybrid method's: each listed triangle's place in its mesh's BVH, and its instance
    TRIANGLE_IDS = 11  # the hybrid method's: the triangle each depth-image sample shows
    RAY_ORIGINS = 12  # the GPU ray query's rays (oracles/ray_query.py)
    RAY_DIRECTIONS = 13
    FRAME = 14  # the viewer's frame, copied into the window (passes/present.py)
    GLYPHS = 15  # the overlay's font (passes/overlay.py)
    # An equirect environment's image, read by every program that includes lib/environment.glsl
    # (passes/environment.py binds it once per frame, before any bake). Past GL 3.3's 16 units per
    # stage as a number, which is allowed: the limit is on the samplers one stage uses (the mirror
    # shader's most is 14, with MATERIAL_TEXELS), and unit numbers run to
    # GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS (>= 48).
    ENVIRONMENT_MAP = 16
    # The scene's image textures (gpu/textures.py), in constants.MATERIAL_ARRAYS texture arrays
    # whatever their number: array k on MATERIAL_ARRAY_k with a repeating sampler (and on
    # MATERIAL_ARRAY_CLAMPED_k with a clamping one, below), read by the diffuse pass alone.
    MATERIAL_ARRAY_0 = 17
    MATERIAL_ARRAY_1 = 18
    MATERIAL_ARRAY_2 = 19
    MATERIAL_ARRAY_3 = 20
    # Every one's level 0 as 8-bit integers, in one atlas, for traced rays: the mirror shader
    # samples this one unit for them all (material_texture.glsl).
    MATERIAL_TEXELS = 21
    # The frame's reflector surfaces (targets.py), read by the deferred mirror shader: with them
    # it samples at most 16 textures, GL 3.3's least GL_MAX_TEXTURE_IMAGE_UNITS.
    SURFACE_POSITION = 22
    SURFACE_NORMAL = 23
    # The baked images' prefiltered colours, read by a glossy mirror's cone (methods/colour_mips.py).
    COLOUR_MIPS = 24
    # What the eye-dependent methods look up at a pixel (methods/planar.py, methods/screen_space.py):
    # a flat mirror's image of the scene through its plane, or the frame's copy after the diffuse
    # pass; and beside it the world position and object id seen there.
    SCREEN_COLOR = 25
    SCREEN_SURFACE = 26
    SSR_PYRAMID = 27  # SSR's min-depth pyramid of the frame (methods/screen_space.py)
    # The same texture arrays as MATERIAL_ARRAY_k, with a clamping sampler: the textures that clamp
    # or mirror on an axis (the diffuse pass folds their UV itself).
    MATERIAL_ARRAY_CLAMPED_0 = 28
    MATERIAL_ARRAY_CLAMPED_1 = 29
    MATERIAL_ARRAY_CLAMPED_2 = 30
    MATERIAL_ARRAY_CLAMPED_3 = 31
    # An equirect sky's image with its mip chain, read by its prefilter alone (passes/environment.py:
    # once per sky, before any bake; released after). What the prefilter makes is kept in the
    # ENVIRONMENT_MAP texture, below the image: the shaders that shade read no more samplers for it.
    ENVIRONMENT_SOURCE = 32


@unique
class UniformBlock(IntEnum):
    DEPTH_IMAGES = 0  # one reflector's image records (methods/impostors.py)
    SHADOW_MAPS = 2  # the lights' shadow-map records (passes/shadows.py)
    GLASS_INTERIOR = 3  # a glass object's interior-image record (passes/glass.py)
    LIGHTS = 4  # ambient, lights and environment values, read by every program that shades (gpu/scene_blocks.py)
    ANALYTIC_PLANES = 5  # the floors and walls every reflected ray is intersected with (gpu/scene_blocks.py)
    TEXTURE_RECORDS = 6  # every image texture's array, layer, wraps and atlas rectangle (gpu/textures.py)
    MATERIALS = 7  # every shaded material's record, read by every pass (gpu/scene_blocks.py)
    DRAWN_MATERIAL = 8  # the drawn object's record alone, bound per draw (gpu/scene_blocks.DrawnMaterials)
    DEFORM_POSE = 9  # a deforming glTF part's joint matrices and morph weights at a time (gpu/deform.py)


@unique
class StorageBuffer(IntEnum):
    PYRAMID_TILES = 0  # the pyramid build's tile table (methods/pyramid.py, depth_pyramid.comp)
    DEPTH_IMAGES = 1  # one reflector's image records, where they pass a uniform block (methods/atlas.py)
    MATERIALS = 2  # the MaterialRecords table, where it passes a uniform block (gpu/scene_blocks.py)
    # Deforming glTF parts on the GPU (gpu/deform.py, methods/gpu_refit.py), within GL 4.3's least
    # of 8 bindings: the mesh arena's vertices (deform.comp writes them, the refit reads them); a
    # part's rest pose, influences and morph deltas; its pose at a time (joint matrices, morph
    # weights); what one refit dispatch goes over (triangles' corners, or nodes); the roots' boxes.
    ARENA = 3
    DEFORM_PART = 4
    DEFORM_POSE = 5  # (where it is past the uniform block's rows: UniformBlock.DEFORM_POSE)
    REFIT_ITEMS = 6
    REFIT_ROOTS = 7


#: A bit per baked image a frame's reflected rays may enter (methods/entered_images.py). GL 4.3
#: guarantees 8 storage-buffer bindings, all taken above, so it shares PYRAMID_TILES's: both are
#: bound just before their own draw or dispatch (the entered-images pass runs before the bake, the
#: pyramid build after it) and neither pass reads the other's buffer. (Not a member of
#: StorageBuffer: an enum's second name for a value is an alias its iteration skips.)
STORAGE_ENTERED_IMAGES = StorageBuffer.PYRAMID_TILES


@unique
class ImageUnit(IntEnum):
    PYRAMID_SOURCE = 0  # the level a pyramid level is built from
    PYRAMID_TARGET = 1  # the level being built
    COLOUR_ATLAS = 2  # the colour mips' first source: the atlas's RGBA8 colour (methods/colour_mips.py)
    BVH_NODES = 3  # the BVH's node texture, refitted in place (methods/gpu_refit.py)
    BVH_TRIANGLES = 4  # its triangle texture, the deformed triangles written over the old


def glsl_bindings() -> dict[str, str]:
    """The storage, image and uniform-block bindings as GLSL defines (STORAGE_PYRAMID_TILES,
    IMAGE_PYRAMID_SOURCE, BLOCK_DEFORM_POSE, ...),
    for the shaders that must name them in a layout qualifier."""
    defines = {f"STORAGE_{member.name}": str(int(member)) for member in StorageBuffer}
    defines["STORAGE_ENTERED_IMAGES"] = str(int(STORAGE_ENTERED_IMAGES))
    defines.update({f"IMAGE_{member.name}": str(int(member)) for member in ImageUnit})
    defines.update({f"BLOCK_{member.name}": str(int(member)) for member in UniformBlock})
    return defines
