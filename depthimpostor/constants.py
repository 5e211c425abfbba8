"""Values shared by Python and GLSL, defined once here and injected into every shader.

`glsl_constants()` turns them into `#define` lines; the std140 structs (`DEPTH_IMAGE`,
`LIGHTING`, ...: gpu/std140.py) are declared in GLSL (gpu/shaders.py's generated files) and packed
in Python (their `.dtype`) from one description. No GLSL file spells out any of these.
"""

from __future__ import annotations

from enum import IntEnum

from .gpu.bindings import glsl_bindings
from .gpu.std140 import Struct


class Algorithm(IntEnum):
    """How a ray is intersected with a depth image: the lecture's two linear marches, and the
    hierarchical traversal that finds the optimized march's hit in a logarithmic number of steps."""

    BASIC = 0  # unproject every step and intersect 3-D segments
    OPTIMIZED = 1  # intersect 2-D segments in OpenGL depth, no unprojection
    HIERARCHICAL = 2  # the optimized march's steps, spans that cannot hit skipped by a min/max pyramid
    AUTO = 3  # per image, the one of the two above that bench measured faster at its size (image_algorithm)

    @property
    def builds_pyramids(self) -> bool:
        """May an image be traversed hierarchically, and so need its depth pyramid?"""
        return self in (Algorithm.HIERARCHICAL, Algorithm.AUTO)


#: `--algorithm auto` traverses an image hierarchically from this larger side up, linearly (the
#: optimized march) below it: where the pyramid's logarithmic steps pay for their set-up and extra
#: texel reads. results/llvmpipe/auto_algorithm.md (`depthimpostor bench scenes/default.toml
#: scenes/lecture_8x9.toml --methods depth --algorithms optimized,hierarchical --resolutions
#: 256,512,1024`): the hierarchical mirror pass wins at 1024^2 on both scenes and loses at 512^2.
HIERARCHICAL_MIN_SIDE = 1024


def image_algorithm(algorithm: Algorithm, width: int, height: int) -> Algorithm:
    """The traversal an image of `width` x `height` is marched with under `algorithm`."""
    if algorithm != Algorithm.AUTO:
        return algorithm
    return Algorithm.HIERARCHICAL if max(width, height) >= HIERARCHICAL_MIN_SIDE else Algorithm.OPTIMIZED


class Method(IntEnum):
    """How a reflected ray finds what it sees: the lecture's stand-ins for the reflected
    geometry, and the real triangles. The viewer cycles through them in this order."""

    DEPTH = 0  # depth-image impostors: one per mirror and reflected object
    CUBEMAP = 1  # a cube map from the mirror's centre, looked up by direction alone
    CUBEMAP_PARALLAX = 2  # the same cube map, its lookup corrected against a proxy box
    BILLBOARD = 3  # one textured quad per mirror and reflected object
    SIMPLIFIED = 4  # decimated triangles, through the ray-traced method's BVH
    RAYTRACE = 5  # the real triangles, through a BVH traversed in the mirror shader
    HYBRID = 6  # depth images, and the real triangles for the rays they cannot answer (Unseen)
    PLANAR = 7  # flat mirrors: the scene rendered again through each mirror's plane (methods/planar.py)
    SSR = 8  # screen-space reflections: a march through the eye's own depth (methods/screen_space.py)

    @property
    def option(self) -> str:
        """The name on the command line: `cubemap-parallax`."""
        return self.name.lower().replace("_", "-")

    @classmethod
    def from_option(cls, option: str) -> Method:
        return cls[option.upper().replace("-", "_")]


class Unseen(IntEnum):
    """Why a depth image's answer to a ray rests on what the image does not hold (the first reason
    met along the ray; shaders/lib/depth_image.glsl and depthimpostor/oracles/reference.py define them
    with these names). A depth image holds, per sample, the visible surface and the back of its
    first solid run: the space in front of the surface is known empty, the run is known solid, and
    nothing is known behind the run or between samples across a silhouette."""

    NONE = 0  # the answer rests on seen surface and seen empty space alone
    HIDDEN_ENTRY = 1  # the ray is inside a solid run without crossing the visible surface: it
    #                   entered through a side the image's eye does not see (where, and its colour, unknown)
    OCCLUDED = 2  # the ray passed behind a solid run: space the object hides from the eye
    SILHOUETTE = 3  # the ray passed within a texel of a silhouette (samples that are not one surface)
    #                 no farther in front of the nearest surface than SILHOUETTE_BAND_TEXELS of its
    #                 steepest slope, or in front of a join and behind the extension of the join beside
    #                 it (an edge between samples), or hit a join steeper than STEEP_JOIN_SHARE of the
    #                 steepest or within a texel of a silhouette: a hit between the samples and a miss
    #                 are both consistent with them
    PENDING = 4  # the ray entered the bound of an image not baked yet (a bake spread over frames:
    #              BakedImages.bake_budget): it holds nothing yet; the hybrid method traces the ray


class MaterialKind(IntEnum):
    DIFFUSE = 0
    CHECKER = 1
    MIRROR = 2
    METALLIC_ROUGHNESS = 3  # glTF 2.0's material model (lib/brdf.glsl, oracles/brdf.py)


class Sides(IntEnum):
    """Which faces of a material's surface are there, and how a back face is shaded (a material
    record's `double_sided`: glTF's doubleSided, and what a TOML scene's surfaces always were)."""

    SINGLE = 0  # doubleSided false: a back face is not there (culled; a ray passes through it)
    DOUBLE = 1  # doubleSided true: a back face is shaded turned round (its normal and normal map's frame)
    AS_FRONT = 2  # both faces there, a back face shaded as the front is (TOML's default)


class Wrap(IntEnum):
    """A texture's wrap mode along one axis: GL's own enum values, which glTF's samplers use too."""

    REPEAT = 10497
    CLAMP_TO_EDGE = 33071
    MIRRORED_REPEAT = 33648


class ToneMapping(IntEnum):
    """How linear colour is compressed into [0, 1] for display (`render.tone_mapping`,
    depthimpostor/colour.py and shaders/lib/display.glsl; docs/colour.md)."""

    NONE = 0  # clamped to [0, 1]
    ACES = 1  # Narkowicz's 2015 fit of the ACES filmic curve
    REINHARD = 2  # x / (1 + x)

    @property
    def option(self) -> str:
        return self.name.lower()


#: `render.samples`: the sub-pixel positions a supersampled frame is drawn at, in pixels from each
#: pixel's centre (x right, y down), one frame per position, averaged in linear colour
#: (renderer.py, docs/colour.md). 1: the centre, today's frame exactly. 4: the rotated grid, and
#: 8: the "8 rooks" pattern, both Direct3D's standard multisample positions (in 1/16 pixel), so
#: that no two samples share a row or a column and near-horizontal and near-vertical edges get
#: as many intermediate levels as there are samples.
SAMPLE_OFFSETS: dict[int, tuple[tuple[float, float], ...]] = {
    1: ((0.0, 0.0),),
    4: tuple((x / 16.0, y / 16.0) for x, y in ((-2, -6), (6, -2), (-6, 2), (2, 6))),
    8: tuple((x / 16.0, y / 16.0) for x, y in ((1, -3), (-1, 3), (5, 1), (-3, -5), (-5, 5), (-7, -1), (3, 7),
                                                (7, -7))),
}


class LightKind(IntEnum):
    DIRECTIONAL = 0
    POINT = 1


class ShadowKind(IntEnum):
    """A light's shadows (scene files: `shadows = "none" | "hard" | "soft"`)."""

    NONE = 0
    HARD = 1  # of the light's centre: one ray to it
    SOFT = 2  # of a sphere about it: SOFT_SHADOW_RAYS rays to points of its disk


#: Lights a scene may have; the shading chunk loops over a uniform array of this size.
MAX_LIGHTS = 8
#: Rays a soft shadow sends toward the light's disk at every shaded point: its visibility is the
#: share that reach it, in SOFT_SHADOW_RAYS + 1 levels. More rays smooth the penumbra's steps
#: and cost a depth-image march each.
SOFT_SHADOW_RAYS = 8
#: A shaded point's shadow ray starts this many shadow-map texels (the texel's width at the point's
#: distance from the light) off the surface, along its normal. A planar surface at angle theta
#: to the light moves away from the light by the offset / cos(theta) in depth, while within the
#: half diagonal (0.71 texel) of a texel its depth varies by up to 0.71 texel * tan(theta): an
#: offset of 0.71 texel * sin(theta) clears every texel's sample at every angle (no acne; the
#: bias scales with the slope by itself). 1.5 leaves room for curvature. It is small enough
#: that a point beside a contact stays outside the touching caster (no light leaks under it).
SHADOW_NORMAL_OFFSET_TEXELS = 1.5
#: render.max_bounces at most: each bounce k >= 2 bakes one depth image per pair of mirrors.
MAX_BOUNCES = 4
#: The largest magnitude of any number in a scene (a coordinate, a length, a scale, a colour) and
#: the farthest any point of an object may reach from the origin. Geometry is float32 on the GPU
#: and in the ray-traced truth, whose largest finite value is 3.4e38; the shaders square
#: distances (dot products, the ray-sphere quadratic), so a distance must stay under
#: sqrt(3.4e38 / 3) = 1.1e19 for a squared length of three coordinates to stay finite.
MAX_COORDINATE = 1e18
#: The largest index of refraction a glass may have (diamond's is 2.42): past it nearly all
#: light reflects at the first surface and nothing is left to refract.
MAX_IOR = 4.0
#: Reflections a ray refracted into glass may make inside it (the Fresnel share reflected at the
#: surface it meets, all of it past the critical angle) before it gives up: what is still inside
#: then carries no light, in the shader and in the truth alike. Each one is a march across the
#: glass's interior image and a ray traced from where it leaves.
MAX_INTERNAL_REFLECTIONS = 2
#: A path inside glass whose share of the light is below this (one 8-bit step of a colour <= 1)
#: is not followed further.
MIN_PATH_WEIGHT = 1.0 / 256.0
#: glTF's alphaMode BLEND along a traced ray (the reflector shader's and the truth's): blended
#: surfaces composited front to back ("over") before the ray takes the next surface it meets as
#: opaque. Each is another trace of the ray from just past the last one; four panes of alpha 0.5
#: leave 1/16 of what lies behind them, which the fifth surface then stands for whole.
BLEND_LAYERS = 4
#: What holds one surface a texel (baked images: depth images, cube maps, billboards; shadow maps)
#: holds a blended surface where its alpha is at least this, as opaque, and nothing where it is
#: less (glTF's MASK at this cutoff): the surface stands for at most half of what it covers.
BLEND_IMAGE_CUTOFF = 0.5
#: Where a traced ray goes on past a blended surface it composited (as a share of the hit's ray
#: parameter, and in world units beside it): the truth's RAY_START_OFFSET, so that float32 does not
#: meet the same surface again.
BLEND_RESTART_OFFSET = 1e-4
#: The sRGB transfer function (IEC 61966-2-1): a linear value c <= SRGB_LINEAR_LIMIT is encoded as
#: SRGB_LINEAR_SLOPE * c, a larger one as (1 + SRGB_OFFSET) * c^(1 / SRGB_GAMMA) - SRGB_OFFSET.
SRGB_LINEAR_LIMIT = 0.0031308
SRGB_LINEAR_SLOPE = 12.92
SRGB_OFFSET = 0.055
SRGB_GAMMA = 2.4
#: Narkowicz's 2015 fit of the ACES filmic tone curve ("ACES Filmic Tone Mapping Curve"):
#: f(x) = clamp(x (A x + B) / (x (C x + D) + E), 0, 1), per channel.
ACES_A, ACES_B, ACES_C, ACES_D, ACES_E = 2.51, 0.03, 2.43, 0.59, 0.14
#: Analytic planes (floors, walls) a reflected ray is intersected with exactly: the scene's largest
#: diffuse planes, up to this many (Scene.analytic_plane_indices); any others are drawn as meshes.
MAX_ANALYTIC_PLANES = 8
#: Texture arrays the rasterized passes sample the scene's image textures from, whatever their
#: number (texture_layout.py): textures are grouped by size into at most this many arrays, each
#: bound on two units (a repeating and a clamping sampler: bindings.TextureUnit.MATERIAL_ARRAY_*),
#: which the diffuse pass picks by an if-chain (GLSL 3.30 indexes an array of samplers only with
#: constants). 4 arrays spend 8 of a fragment shader's 16 samplers; a scene with more distinct
#: sizes has some of its images resampled to a larger size of its group (texture_layout.py).
MATERIAL_ARRAYS = 4
#: The depth-image records a mirror's uniform block holds: 64 x 208 bytes = 13 KiB, under the
#: 16 KiB every GL 3.3 guarantees a uniform block. A mirror may own any number of images (one per
#: reflected object): where a scene may give one more than this, its programs read the records
#: from a storage buffer instead (GL 4.3), which is as large as memory allows (depth_image_capacity).
DEPTH_IMAGE_BLOCK_RECORDS = 64


#: The smallest side render.image_memory's budget lowers depth images to (baked_images.budgeted_side).
MIN_BUDGETED_SIDE = 8


#: Storage buffers arrived with OpenGL 4.3 (GL_ARB_shader_storage_buffer_object): ctx.version_code.
STORAGE_GL_VERSION = 430


def depth_image_capacity(objects: int) -> int:
    """The records a mirror's image table is declared with in a scene of `objects` objects: the
    uniform block's DEPTH_IMAGE_BLOCK_RECORDS, or, past it, the next power of two (a mirror
    shows at most every other object, or six cube faces). It is the mirror shader's constant loop
    bound (lib/reflected_scene.glsl says why a constant) and a program define, so that scenes
    of a similar size share programs."""
    return max(DEPTH_IMAGE_BLOCK_RECORDS, 1 << max(0, objects - 1).bit_length())


#: The record tables from which a mirror's images are found through lists (lists_images): every
#: table of a storage buffer (the first capacity past the uniform block's).
IMAGE_CELLS_MIN_CAPACITY = 2 * DEPTH_IMAGE_BLOCK_RECORDS


def lists_images(capacity: int) -> bool:
    """Are a mirror's images of a table of `capacity` records found through lists of candidates
    by ray (IMAGE_CELLS, methods/image_cells.py), which the table then holds past its records,
    rather than by scanning every bound? Wherever the table is a storage buffer: at 100 images
    (tools/scene_size.py's family, 960x540) a ray's list holds 2 where the scan tests 100, and the
    images visited, and their order, are the scan's."""
    return capacity >= IMAGE_CELLS_MIN_CAPACITY


def depth_image_defines(capacity: int) -> dict[str, int]:
    """The defines of a program reading a mirror's image tables of `capacity` records
    (lib/baked_images.glsl): none for the uniform block's own size, so that a scene of up to
    DEPTH_IMAGE_BLOCK_RECORDS objects keeps the programs it always had; past it the capacity, the
    storage buffers' extension, and IMAGE_CELLS: the images found through the lists their table
    holds past the records (methods/image_cells.py)."""
    if capacity <= DEPTH_IMAGE_BLOCK_RECORDS:
        return {}
    lists = {"IMAGE_CELLS": 1} if lists_images(capacity) else {}
    return {"DEPTH_IMAGE_CAPACITY": capacity, "NEEDS_STORAGE_BLOCKS": 1, **lists}


#: Reflected triangles the hybrid method's depth images can name: a float32 sample holds
#: integers below 2^24.
MAX_NAMED_TRIANGLES = 2**24
#: A depth-image sample at or beyond this OpenGL depth is background: nothing was rasterized there.
BACKGROUND_DEPTH = 1.0
#: Object id reported for a reflected ray that hit nothing (the environment).
NO_OBJECT = -1
#: The steepest surface (tangent of the angle between its normal and the line of sight) that
#: two neighbouring depth-image samples may still be joined across. A steeper step in depth is
#: taken for a depth discontinuity (a silhouette over something farther away), and joining it
#: would make a "rubber sheet" that reflected rays hit where nothing is. tan(86.4 deg) = 16: a
#: sphere loses only the last ~0.2 % of its radius at the silhouette to this rule.
MAX_SURFACE_SLOPE = 16.0
#: Near a silhouette the surface between two samples is not sampled; it may come nearer the eye
#: than the sample beside it by up to this many texels of the steepest slope two samples are joined
#: across (MAX_SURFACE_SLOPE): half a texel because a sample stands for its texel's centre while
#: the march reads it anywhere in the texel, and the rest for surfaces that steepen toward their
#: silhouette (a sphere's rim). A ray that crosses a silhouette nearer to the surface's depth than
#: that is Unseen.SILHOUETTE.
SILHOUETTE_BAND_TEXELS = 2.0
#: A hit between two joined samples whose depth step is steeper than this share of the steepest
#: join (MAX_SURFACE_SLOPE) may be on a "rubber sheet" over a gap between two surfaces close in
#: depth (strands of a knot, one behind the other): it is Unseen.SILHOUETTE too.
STEEP_JOIN_SHARE = 0.5
#: The hybrid method makes a certain hit exact by intersecting the ray with the triangles the
#: samples around it show; an intersection farther than this share of the hit's t from it is
#: another surface (the hit's own is within the image's sampling of it: a few texels' footprint,
#: over the cosine of a steep surface's slope), and without one the ray is traced instead.
EXACT_SURFACE_WINDOW = 0.05
#: An image holds the surface its eye sees: the hybrid method's exact hit is held (and the ray not
#: traced) only if no triangle that the samples around the hit's image show on the same layer lies
#: between the image's eye and the hit. A triangle met before this share of the way from the eye to the hit
#: hides it; nearer the hit is the float32 rounding of the hit and of the intersection (about
#: 1e-6 of the way), which a neighbour sharing an edge with the hit's triangle can show.
HIDDEN_HIT_MARGIN = 1e-4
#: The ray counts as touching the surface where their OpenGL depths differ by at most this (8
#: float32 steps of depths in [0.5, 1]). Both are rounded float32 values: without a tolerance, a
#: ray lying in a surface sees the sign of (ray - surface) flip at random from pixel to pixel,
#: and "first front-to-back crossing" lands anywhere along it (flicker as the camera moves).
CONTACT_DEPTH_TOLERANCE = 2.0**-21

#: A span of the min/max depth pyramid over background alone holds (EMPTY_SPAN_MIN,
#: EMPTY_SPAN_MAX): no ray depth (OpenGL depths in [0, 1], a rounding step beyond after clipping)
#: can meet an interval that starts above it and ends below it.
EMPTY_SPAN_MIN = 2.0
EMPTY_SPAN_MAX = -1.0

#: The basic algorithm's closest approach of two lines divides by aa cc - bb^2 = aa cc sin^2 of
#: their angle. Below this share of aa cc (0.2 degrees) float32 rounding, relative 1e-7 of aa cc,
#: is a visible part of it, and the 2-D intersection in depth is used instead.
MIN_LINES_SINE_SQUARED = 1e-5
#: Rays are clipped to the frustum grown by this many pixels on each side (and by this share of
#: a pixel's angle at the near and far planes): a ray that runs along a side plane, an edge or a
#: corner is then inside whatever the last bit of rounding says, and GPU and reference agree. Its
#: samples beyond the border read the border texel (texel_of clamps).
CLIP_TOLERANCE_PIXELS = 1e-4

#: Triangles the viewer's frame may draw in bakes where its method can answer the rays of images
#: not baked yet otherwise (the hybrid traces them; GraphOptions.bake_budget): a thousand objects'
#: first frame would otherwise wait for all the layers of the images it enters (about 9 M triangles,
#: 3 s of llvmpipe), where this is a tenth of a second of llvmpipe's and a fraction of a GPU's
#: millisecond; the images come in over the next frames (tools/startup_time.py --bake-budget;
#: results/llvmpipe/startup_time.md).
INTERACTIVE_BAKE_BUDGET = 250_000

#: The std140 record of one depth image, as vec4 / ivec4 rows. `eye.w` holds the object id,
#: `inverse_row*` are the rows of [a b c]^-1 (projection into the camera's (x, y, w)),
#: `depth_range` is (w_near, w_far, width, height), `tile` the (x, y) pixel origin of the image
#: in the atlas and its size; `surface` is (the largest relative change in w per texel of
#: distance that still joins two samples, 1/w_near, 1/w_near - 1/w_far, and 1 while the image waits
#: for a bake a frame deferred, else 0: BakedImages.bake_budget); `pyramid` the (x, y)
#: origin of the image's first coarse level in the depth pyramid's texture and its number of
#: coarse levels (methods/pyramid.py; read by the hierarchical traversal alone); `bound` a sphere
#: (world centre, radius) around every point the image can answer a ray with (PPC.bound): a ray
#: that misses it misses the image, and a ray meets nothing in the image before it enters it (the
#: mirror shader visits a mirror's images in that order and stops early: lib/reflected_scene.glsl);
#: `hit_bound` a sphere that holds every hit the image can give (PPC.hit_bound: its object's
#: sphere grown by what sampling adds, where it is smaller than `bound`), which the variants that
#: do not track unseen space (they need nothing of an image but its hits) order and skip by.
DEPTH_IMAGE_FIELDS: tuple[tuple[str, str], ...] = (
    ("eye", "vec4"),
    ("a", "vec4"),
    ("b", "vec4"),
    ("c", "vec4"),
    ("inverse_row0", "vec4"),
    ("inverse_row1", "vec4"),
    ("inverse_row2", "vec4"),
    ("depth_range", "vec4"),
    ("tile", "ivec4"),
    ("surface", "vec4"),
    ("pyramid", "ivec4"),
    ("bound", "vec4"),
    ("hit_bound", "vec4"),
)
#: The share by which a depth image's bound is larger than the sphere around its grown frustum:
#: the shaders clip in float32, whose rounding moves the entry into the frustum by ~1e-6 of the
#: distance; a bound entered 1e-3 of its radius earlier stays in front of it for an object up to
#: ~1000 radii away from the mirror.
BOUND_MARGIN = 1e-3

#: One reflected object of the traced methods, an instance of a mesh in their two-level BVH
#: (methods/triangles.py), stored as texels of the BVH's node texture (gpu/texel_records.py): the
#: world-to-local transform (the ray goes through it into the mesh's space, and the checker is
#: laid out in local coordinates), (material index in the MaterialRecords table, object id, 0, 0),
#: and in mesh.x the node where its mesh's bottom-level hierarchy starts.
TRIANGLE_INSTANCE_FIELDS: tuple[tuple[str, str], ...] = (
    ("world_to_local", "mat4"),
    ("ids", "ivec4"),
    ("mesh", "ivec4"),
)
#: Width of the float textures holding BVH nodes and triangles: element i is texel
#: (i % width, i / width). 1024 is the smallest GL_MAX_TEXTURE_SIZE GL 3.3 allows; the height
#: grows with the count and is checked against the driver's own limit.
BVH_TEXTURE_WIDTH = 1024
#: Texels one triangle takes in the BVH's triangle texture, in its mesh's space: its corners p0 p1
#: p2, its corner normals n0 n1 n2, and its corner UVs (u0 v0 u1 v1), (u2 v2 0 0).
BVH_TRIANGLE_TEXELS = 8
#: The optional vertex attributes of a mesh beyond position, normal and TEXCOORD_0 (meshes.Mesh's
#: fields) and their widths, in the order the GPU's extra vertex buffer (gpu/meshes.py) and the
#: triangle texture hold them.
EXTRA_ATTRIBUTES = {"uvs1": 2, "colors": 4, "tangents": 4}
#: What a mesh without one of them reads in a scene whose other meshes have it (lib/mesh_point.glsl's
#: mesh_point too): no second UV set, white (a vertex colour multiplies the base colour), no
#: tangent (only a normal-mapped material reads one, and its meshes have them).
EXTRA_DEFAULTS = {"uvs1": (0.0, 0.0), "colors": (1.0, 1.0, 1.0, 1.0), "tangents": (0.0, 0.0, 0.0, 1.0)}
#: Texels a triangle takes past those for each glTF vertex attribute a scene may add (meshes.py's
#: EXTRA_ATTRIBUTES), in this order: TEXCOORD_1's first two corners (u0 v0 u1 v1) in one, the
#: third's in the free half of the last UV texel; the three corners' colours; their tangents.
TRIANGLE_ATTRIBUTE_TEXELS = {"uvs1": 1, "colors": 3, "tangents": 3}


def triangle_texel_layout(attributes: tuple[str, ...]) -> dict[str, int]:
    """Where the triangle texture holds a scene's extra vertex attributes (`attributes`, a subset
    of TRIANGLE_ATTRIBUTE_TEXELS's names): lib/triangles.glsl's defines, TRIANGLE_TEXELS (texels a
    triangle) and each attribute's first texel (TRIANGLE_UVS1_TEXEL...); methods/triangles.py
    writes them there. Nothing for a scene without any: BVH_TRIANGLE_TEXELS a triangle."""
    if not attributes:
        return {}
    layout, texel = {}, BVH_TRIANGLE_TEXELS
    for name, texels in TRIANGLE_ATTRIBUTE_TEXELS.items():
        if name in attributes:
            layout[f"TRIANGLE_{name.upper()}_TEXEL"] = texel
            texel += texels
    return {"TRIANGLE_TEXELS": texel, **layout}


#: How a mirror's lists of candidate images by ray are laid out (methods/image_cells.py): the
#: sphere its reflected rays start in, and (cells per side of a cube face's directions, of its
#: offsets, the cell count, the image count).
IMAGE_GRID_FIELDS: tuple[tuple[str, str], ...] = (
    ("sphere", "vec4"),
    ("size", "ivec4"),
)

DEPTH_IMAGE = Struct("DepthImage", DEPTH_IMAGE_FIELDS)
IMAGE_GRID = Struct("ImageGrid", IMAGE_GRID_FIELDS)
IMAGE_GRID_DTYPE = IMAGE_GRID.dtype
TRIANGLE_INSTANCE = Struct("TriangleInstance", TRIANGLE_INSTANCE_FIELDS)
DEPTH_IMAGE_DTYPE = DEPTH_IMAGE.dtype
TRIANGLE_INSTANCE_DTYPE = TRIANGLE_INSTANCE.dtype

#: One image texture of the scene (texture slot k is record k of lib/material_texture.glsl's
#: TextureRecords block, gpu/textures.py): `sampling` is (texture array, layer, wrap s, wrap t),
#: the wrap modes GL enums (Wrap); `texels` where its level 0 lies in the traced rays' 8-bit atlas,
#: (x, y, width, height) (texture_layout.py); its UV transform and colour space.
TEXTURE_RECORD = Struct("TextureRecord", (
    ("sampling", "ivec4"),
    ("texels", "ivec4"),
    ("uv_u", "vec3"),  # the UV transform (Texture.uv_rows): u' = dot(uv_u, (u, v, 1)), v' = dot(uv_v, (u, v, 1))
    ("srgb", "int"),  # 1: colour, decoded from sRGB; 0: data, as stored
    ("uv_v", "vec3"),
    ("uv_set", "int"),  # the mesh's UV set it reads: 0 (TEXCOORD_0) or 1 (TEXCOORD_1)
))

#: A surface's material as lib/shading.glsl's material_albedo reads it: MATERIAL_DIFFUSE or
#: MATERIAL_CHECKER, the two colours (a diffuse material's is color_a), the checker's cell size,
#: a diffuse material's texture slot (or -1). Every pass reads
#: one table of them (lib/shading.glsl's MaterialRecords block, written once by
#: gpu/scene_blocks.py): an object, an instance, a triangle instance and a plane carry an index.
MATERIAL = Struct("Material", (
    ("kind", "int"),
    ("color_a", "vec3"),
    ("scale", "float"),
    ("color_b", "vec3"),
    # MATERIAL_METALLIC_ROUGHNESS alone: metalness, perceptual roughness (alpha = roughness^2), the
    # emitted radiance, and the slots (or -1) of its metallic-roughness, occlusion and emissive maps.
    ("metallic", "float"),
    ("emissive", "vec3"),
    ("roughness", "float"),
    ("texture", "int"),
    ("metallic_roughness_texture", "int"),
    ("occlusion_texture", "int"),
    ("emissive_texture", "int"),
    ("alpha_cutoff", "float"),  # glTF's alphaMode MASK: the cutoff (< 0: opaque)
    ("alpha", "float"),  # and the base colour factor's alpha, times the texture's
    ("occlusion_strength", "float"),
    ("normal_texture", "int"),  # the normal map's slot (or -1), and its scale of x and y
    ("normal_scale", "float"),
    ("blend", "int"),  # 1: glTF's alphaMode BLEND (alpha_cutoff is then BLEND_IMAGE_CUTOFF, for the images)
    ("double_sided", "int"),  # Sides: which faces are there, and how a back face is shaded
))

#: Material records a uniform block holds within GL 3.3's guaranteed 16 KiB (146 records of 112 bytes). A scene of more
#: distinct materials reads its MaterialRecords table from a storage buffer (GL 4.3) instead, as
#: large as memory allows: std430 lays the record out as std140 does (every member within a vec4,
#: the struct a multiple of 16 bytes), so one numpy record type fills either.
MATERIAL_BLOCK_RECORDS = 16384 // MATERIAL.dtype.itemsize

#: Bytes from one record to the next in the copy of the MaterialRecords table that a program drawing
#: one object a call binds a record of (lib/shading.glsl's DrawnMaterial block, bound with
#: glBindBufferRange: gpu/scene_blocks.DrawnMaterials): the record rounded up to 256, the largest
#: GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT a GL may ask (OpenGL 4.6, table 23.64), so that every context
#: can bind every record and the plan counts the copy without one.
DRAWN_MATERIAL_STRIDE = -(-MATERIAL.dtype.itemsize // 256) * 256

#: One light of the Lights block: LIGHT_DIRECTIONAL or LIGHT_POINT, SHADOW_NONE, SHADOW_HARD or
#: SHADOW_SOFT, the soft shadows' disk radius, the unit travel direction (directional) or the
#: position (point), and colour * intensity.
LIGHT = Struct("Light", (
    ("kind", "int"),
    ("shadows", "int"),
    ("radius", "float"),
    ("vector", "vec3"),
    ("radiance", "vec3"),
))

#: Everything that lights the scene, in the one uniform block every shading program reads
#: (lib/lighting.glsl's Lights, gpu/scene_blocks.py): the ambient term, the lights, and the
#: environment's values (the gradient's colours, or an equirect map's intensity and its rotation
#: about +Y as (cos, sin); the map's image is a texture).
LIGHTING = Struct("Lighting", (
    ("ambient", "float"),
    ("light_count", "int"),
    ("env_rotation", "vec2"),
    ("env_zenith", "vec3"),
    ("env_intensity", "float"),
    ("env_horizon", "vec3"),
    ("env_ground", "vec3"),
    # An equirect sky's image size in texels (its texture holds the prefiltered specular below it:
    # lib/environment_lighting.glsl), and its irradiance as nine spherical-harmonic terms, each
    # already times its basis constant and the cosine lobe's band factor (ibl.py's irradiance_sh9),
    # in vec4s (std140 pads a vec3 array's elements to 16 bytes anyway); zero without a map.
    ("env_size", "ivec2"),
    ("env_irradiance", "vec4", 9),
    ("lights", LIGHT, MAX_LIGHTS),
))

#: An analytic plane (a floor or wall that is not a mirror), the rectangle |x| <= half_size.x,
#: |z| <= half_size.y of its local y = 0 plane: its world-to-local transform, material, unit
#: world-space normal and object id.
ANALYTIC_PLANE = Struct("AnalyticPlane", (
    ("world_to_local", "mat4"),
    ("material", "int"),  # its index in the MaterialRecords table
    ("normal", "vec3"),
    ("object_id", "int"),
    ("half_size", "vec2"),
))

#: The analytic planes every reflected ray is intersected with (lib/reflected_scene.glsl's
#: AnalyticPlanes block, gpu/scene_blocks.py).
PLANES = Struct("Planes", (
    ("count", "int"),
    ("planes", ANALYTIC_PLANE, MAX_ANALYTIC_PLANES),
))


#: `--method ssr` (lib/screen_space.glsl): how thick the march takes every surface the eye sees to
#: be, as a share of its distance w from the eye. The eye's depth holds front surfaces alone, so a
#: ray that passes behind one is taken to hit it while it is within this much behind; a ray farther
#: behind passes on (and may see what the eye does not, which SSR shows as what lies beyond). A
#: share, not a length, so that the scenes' different scales need no setting: 0.03 holds the
#: 0.7-unit box 5 units away (0.15 of w thick) where a reflected ray runs nearly along the eye's
#: view of it for a few pixels, and lets rays pass well behind the spheres' silhouettes.
SSR_THICKNESS = 0.03
#: The most cells one SSR march reads (lib/screen_space.glsl: a pixel, or a cell of its min-depth
#: pyramid skipped whole, or a step up or down the pyramid): twice the larger side of a 1080p
#: frame, room for a ray across the frame at the finest level with steps up and down around what
#: it passes. A ray that has not hit or left the screen by then falls back to the environment.
SSR_MAX_STEPS = 3840
#: The pyramid's w where the eye saw nothing (the sky, and its cells beyond the frame): farther
#: than any ray, so that every ray is in front of it.
SSR_NOTHING = 1e30
#: Where SSR's hits fade to the fallback (the environment): within this share of the frame's
#: half-size from its edge, linearly, so that an object sliding out of the frame does not cut its
#: reflection off at a hard line (the engines' "edge fade").
SSR_EDGE_FADE = 0.1

# glTF 2.0's metallic-roughness model (its specification's Appendix B: lib/brdf.glsl and
# oracles/brdf.py, the same functions by the same names).
#: The Fresnel reflectance of a dielectric at normal incidence (an index of refraction of 1.5).
DIELECTRIC_F0 = 0.04
#: Karis' analytic fit of the split-sum's scale and bias of F0 for a uniform environment
#: ("Physically Based Shading on Mobile", 2014; three.js's DFGApprox): what the ambient light,
#: a constant radiance from every direction, gives a metallic-roughness surface's specular lobe.
DFG_FIT_C0 = (-1.0, -0.0275, -0.572, 0.022)
DFG_FIT_C1 = (1.0, 0.0425, 1.04, -0.04)
DFG_FIT_EXPONENT = -9.28
DFG_FIT_SCALE = 1.04
#: The least roughness the lights' lobe is evaluated at (three.js's): at 0 the GGX distribution is
#: 0 / 0 where N.H = 1 (a point light's highlight of zero width and infinite height).
MIN_ROUGHNESS = 0.0525

# Image-based lighting from an equirect sky (ibl.py, passes/environment.py, lib/environment_lighting.glsl):
#: The prefiltered specular levels below the sky's own image: level k (1..IBL_LEVELS) is the sky
#: seen through GGX lobes of roughness k / IBL_LEVELS; level 0, roughness 0, is the sky itself.
IBL_LEVELS = 5
#: Level 1's width in texels (an equirect map, twice as wide as high); each next level is half as
#: wide. 256 columns are 1.4 degrees each, finer than level 1's lobe (roughness 0.2: alpha 0.04,
#: a lobe some 5 degrees across), as glTF-Sample-Viewer's 256-texel cube faces are for its level 1.
IBL_WIDTH = 256
#: GGX samples per prefiltered texel (Hammersley points, each read from the sky's mip level that
#: its share of the lobe's solid angle covers: GPU Gems 3, 20.4, as glTF-Sample-Viewer's
#: ibl_filtering.frag). 256 rather than 128: at roughness 1 the median error against a numpy sum
#: over every texel halves, to 2 % (tests/test_environment_lighting.py), for twice the prefilter's time.
IBL_SAMPLES = 256


def glsl_constants() -> dict[str, str]:
    """Every shared constant as a GLSL define (name -> value text)."""
    defines: dict[str, str] = {
        "MAX_LIGHTS": str(MAX_LIGHTS),
        "MAX_ANALYTIC_PLANES": str(MAX_ANALYTIC_PLANES),
        "DEPTH_IMAGE_BLOCK_RECORDS": str(DEPTH_IMAGE_BLOCK_RECORDS),
        "MATERIAL_BLOCK_RECORDS": str(MATERIAL_BLOCK_RECORDS),
        "BACKGROUND_DEPTH": f"{BACKGROUND_DEPTH:.1f}",
        "NO_OBJECT": str(NO_OBJECT),
        "CONTACT_DEPTH_TOLERANCE": f"{CONTACT_DEPTH_TOLERANCE!r}",
        "SILHOUETTE_BAND_TEXELS": f"{SILHOUETTE_BAND_TEXELS!r}",
        "STEEP_JOIN_SHARE": f"{STEEP_JOIN_SHARE!r}",
        "EXACT_SURFACE_WINDOW": f"{EXACT_SURFACE_WINDOW!r}",
        "HIDDEN_HIT_MARGIN": f"{HIDDEN_HIT_MARGIN!r}",
        "CLIP_TOLERANCE_PIXELS": f"{CLIP_TOLERANCE_PIXELS!r}",
        "MIN_LINES_SINE_SQUARED": f"{MIN_LINES_SINE_SQUARED!r}",
        "EMPTY_SPAN_MIN": f"{EMPTY_SPAN_MIN!r}",
        "EMPTY_SPAN_MAX": f"{EMPTY_SPAN_MAX!r}",
        "BVH_TEXTURE_WIDTH": str(BVH_TEXTURE_WIDTH),
        "BVH_TRIANGLE_TEXELS": str(BVH_TRIANGLE_TEXELS),
        **{f"DEFAULT_{name.upper()}": f"vec{len(value)}(" + ", ".join(f"{c!r}" for c in value) + ")"
           for name, value in EXTRA_DEFAULTS.items()},
        "SOFT_SHADOW_RAYS": str(SOFT_SHADOW_RAYS),
        "SHADOW_NORMAL_OFFSET_TEXELS": f"{SHADOW_NORMAL_OFFSET_TEXELS!r}",
        "MAX_INTERNAL_REFLECTIONS": str(MAX_INTERNAL_REFLECTIONS),
        "MIN_PATH_WEIGHT": f"{MIN_PATH_WEIGHT!r}",
        "BLEND_LAYERS": str(BLEND_LAYERS),
        "BLEND_RESTART_OFFSET": f"{BLEND_RESTART_OFFSET!r}",
        "SRGB_LINEAR_LIMIT": f"{SRGB_LINEAR_LIMIT!r}",
        "SRGB_LINEAR_SLOPE": f"{SRGB_LINEAR_SLOPE!r}",
        "SRGB_OFFSET": f"{SRGB_OFFSET!r}",
        "SRGB_GAMMA": f"{SRGB_GAMMA!r}",
        "ACES_A": f"{ACES_A!r}", "ACES_B": f"{ACES_B!r}", "ACES_C": f"{ACES_C!r}", "ACES_D": f"{ACES_D!r}",
        "ACES_E": f"{ACES_E!r}",
        "SSR_THICKNESS": f"{SSR_THICKNESS!r}",
        "SSR_MAX_STEPS": str(SSR_MAX_STEPS),
        "SSR_NOTHING": f"{SSR_NOTHING!r}",
        "SSR_EDGE_FADE": f"{SSR_EDGE_FADE!r}",
        "DIELECTRIC_F0": f"{DIELECTRIC_F0!r}",
        "DFG_FIT_C0": "vec4(" + ", ".join(f"{c!r}" for c in DFG_FIT_C0) + ")",
        "DFG_FIT_C1": "vec4(" + ", ".join(f"{c!r}" for c in DFG_FIT_C1) + ")",
        "DFG_FIT_EXPONENT": f"{DFG_FIT_EXPONENT!r}",
        "DFG_FIT_SCALE": f"{DFG_FIT_SCALE!r}",
        "MIN_ROUGHNESS": f"{MIN_ROUGHNESS!r}",
        "IBL_LEVELS": str(IBL_LEVELS),
        "IBL_WIDTH": str(IBL_WIDTH),
        "IBL_SAMPLES": str(IBL_SAMPLES),
    }
    defines.update(glsl_bindings())
    prefixes = {Algorithm: "ALGORITHM", Method: "METHOD", MaterialKind: "MATERIAL", LightKind: "LIGHT",
                ShadowKind: "SHADOW", Unseen: "UNSEEN", Sides: "SIDES", ToneMapping: "TONE_MAPPING", Wrap: "WRAP"}
    for enum, prefix in prefixes.items():
        defines.update({f"{prefix}_{member.name}": str(int(member)) for member in enum})
    return defines
