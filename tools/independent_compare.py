"""Each public model's direct view (no mirror) against pyrender, per pixel (issue 33): the same
triangles at time 0, the same camera and the same two directional lights, no ambient light and a
black background, compared in linear space. Writes results/llvmpipe/independent.md (the figures)
and results/llvmpipe/independent/<model>.png (ours | pyrender | their difference x 4 | the
difference to pyrender made Appendix B's x 4).

    python3 -m venv /tmp/pyr --system-site-packages && /tmp/pyr/bin/pip install pyrender
    PYOPENGL_PLATFORM=egl PYTHONPATH=$PWD /tmp/pyr/bin/python tools/independent_compare.py

Why pyrender: it is a metallic-roughness rasterizer Python users know (it draws trimesh's
scenes, `pip install pyrender`), deterministic (no Monte Carlo noise to tell from a shading
difference, as Mitsuba 3's principled BSDF would have), rasterized with OpenGL's conventions
(pixel centres, perspective, texture filtering) as ours, and its shader is a metallic-roughness
one of the glTF family (GGX, Schlick Fresnel, its factors and maps). It departs from the glTF
specification's Appendix B in known places, which the report takes apart in three renders of
pyrender per model:

- `as written`: pyrender given what the file says (its normal maps, BLEND, MASK as pyrender draws
  them), our triangles at time 0 (skinned and morphed), UVs (through KHR_texture_transform) and
  decoded textures, so that pyrender is compared on shading rather than on a second loader (ours is
  checked by the tests and the truth);
- `same inputs`: what our loader lists as ignored left out of pyrender's material too (today
  KHR_materials_clearcoat alone, which pyrender does not read either: normal maps and BLEND are
  read by both), so that what remains is the shading;
- `Appendix B`: pyrender's shader with its BRDF made the specification's (Smith height-correlated
  visibility on alpha instead of Schlick-GGX on (r + 1)^2 / 8; the diffuse colour not darkened by
  a further 4 %; the 0.04 floor on roughness ours (MIN_ROUGHNESS); no +0.001 in the denominator) and its colour
  textures filtered in linear light (it filters the sRGB-encoded texels, then decodes): what
  remains is rasterization, mipmap levels, 8-bit storage and readback.

Both sides take pyrender's deviations in input out of the picture: its occlusion map darkens the
direct light (the specification: indirect light alone; ours: the ambient term, which is 0 here), so
pyrender gets no occlusion map; it multiplies the emissive factor in twice, so it gets the factor's
square root; its output is clamped and gamma-2.2 encoded in 8 bits, so its lights are scaled by
1/HEADROOM (and the emission alike) and the readback decoded and scaled back.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parent))
from public_models import CATALOGUE, LARGE, PublicModel, model_path  # noqa: E402

from depthimpostor.constants import MIN_ROUGHNESS, Method  # noqa: E402
from depthimpostor.errors import SceneWarning  # noqa: E402
from depthimpostor.geometry import scene_geometry  # noqa: E402
from depthimpostor.plan import ignored_in_files  # noqa: E402
from depthimpostor.scene import Scene, load_scene  # noqa: E402
from depthimpostor.textures import srgb_to_linear  # noqa: E402
from depthimpostor.scene.model import DiffuseMaterial, Environment, Light, MetallicRoughnessMaterial, Texture  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "results" / "llvmpipe" / "independent.md"
SIZE = (256, 192)
#: The two lights, as our scenes give them (unitless: a white diffuse surface facing one shows its
#: intensity); pyrender's radiance is pi times ours (its BRDF is not scaled by pi).
LIGHTS = (Light("directional", direction=(-0.4, -1.0, -0.5), intensity=1.0),
          Light("directional", direction=(0.7, -0.2, -0.6), intensity=0.4))
#: pyrender clamps its output to 1 before its 8-bit gamma encoding: its lights (and emission) are
#: divided by this, and its readback multiplied back, so that highlights up to this survive.
HEADROOM = 4.0
#: Differences over this (linear, largest channel) count as "differ" in the table.
DIFFERS = 0.05
#: A depth step of more than this share of the depth marks a silhouette (edges()).
EDGE_STEP = 0.02
#: glTF's default material (a primitive without one): white, metallic 1, roughness 1.
BLACK = (0.0, 0.0, 0.0)
GLTF_DEFAULT = MetallicRoughnessMaterial((1.0, 1.0, 1.0), metallic=1.0, roughness=1.0)


def our_scene(path: Path) -> Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        scene = load_scene(path)
    render = dataclasses.replace(scene.render, size=SIZE, ambient=0.0)
    return dataclasses.replace(scene, render=render, lights=LIGHTS,
                               environment=Environment("constant", BLACK, BLACK, BLACK, BLACK))


def render_ours(scenes: dict[str, Scene]) -> dict[str, np.ndarray]:
    """Our direct views (linear float), all before pyrender makes its own GL context."""
    from depthimpostor.gpu.context import create_context
    from depthimpostor.renderer import Renderer

    ctx = create_context()
    images = {}
    for name, scene in scenes.items():
        with Renderer(ctx, scene, method=Method.RAYTRACE) as renderer:
            renderer.render()
            images[name] = renderer.read_color_float()
    ctx.release()
    return images


def _pyrender_texture(texture: Texture | None, channels: str, linear: bool = False) -> Any:
    """pyrender's texture of the channels it reads (it takes a Texture as given: the channels are
    picked here as its material setters pick them from an array), with the sampler's wrap modes.
    `linear`: a colour texture decoded from sRGB here (stored in 8 bits linear), for a shader that
    does not decode it after filtering (APPENDIX_B)."""
    import pyrender

    if texture is None:
        return None
    wrap_s, wrap_t = texture.wrap
    sampler = pyrender.Sampler(wrapS=wrap_s, wrapT=wrap_t)
    picked = np.ascontiguousarray(texture.image[..., ["RGBA".index(c) for c in channels]])
    if linear and texture.srgb:
        decoded = picked.astype(np.float32) / 255.0
        decoded[..., :3] = srgb_to_linear(decoded[..., :3])
        picked = np.round(decoded * 255.0).astype(np.uint8)
    return pyrender.Texture(source=picked, source_channels=channels, sampler=sampler)


def _uvs(mesh_uvs: np.ndarray, texture: Texture | None) -> np.ndarray:
    """The mesh's UVs through the base colour texture's transform, in pyrender's convention (v up:
    it flips images as it uploads them, as trimesh's loader flips v)."""
    uv = np.asarray(mesh_uvs, np.float64)
    if texture is not None:
        (a, b, c), (d, e, f) = texture.uv_rows
        uv = np.stack([a * uv[:, 0] + b * uv[:, 1] + c, d * uv[:, 0] + e * uv[:, 1] + f], axis=1)
    return np.stack([uv[:, 0], 1.0 - uv[:, 1]], axis=1).astype(np.float32)


def _material(material: Any, header_material: dict[str, Any] | None, variant: str) -> Any:
    """pyrender's material for one of ours (and the file's JSON material, whose normal map and
    BLEND pyrender is handed as the file writes them), as `variant` asks."""
    import pyrender

    if not isinstance(material, MetallicRoughnessMaterial):
        # A part without a material: glTF's default; a mirror or glass (none among these models).
        if isinstance(material, DiffuseMaterial) and header_material is None:
            material = GLTF_DEFAULT
        else:
            raise ValueError(f"no pyrender counterpart for {type(material).__name__}")
    emissive = np.sqrt(np.maximum(np.asarray(material.emissive, np.float64), 0.0) / HEADROOM)  # drawn squared
    alpha_mode = "MASK" if material.alpha_cutoff is not None else "OPAQUE"
    normal = None
    if header_material is not None:
        # As written: whatever the file says; the other columns: what our loader reads of it too.
        written = variant == "as written"
        if header_material.get("alphaMode") == "BLEND" and (written or material.blend):
            alpha_mode = "BLEND"
        if written or material.normal_texture is not None:
            normal = header_material.get("_normal")
    return pyrender.MetallicRoughnessMaterial(
        baseColorFactor=[*material.color, material.alpha], metallicFactor=material.metallic,
        roughnessFactor=material.roughness, emissiveFactor=emissive.tolist(), alphaMode=alpha_mode,
        alphaCutoff=material.alpha_cutoff if material.alpha_cutoff is not None else 0.5,
        # As the file says (ours culls a single-sided material's back faces, as pyrender does).
        doubleSided=material.double_sided is not False,
        baseColorTexture=_pyrender_texture(material.texture, "RGBA", variant == "Appendix B"),
        metallicRoughnessTexture=_pyrender_texture(material.metallic_roughness_texture, "GB"),
        emissiveTexture=_pyrender_texture(material.emissive_texture, "RGB", variant == "Appendix B"),
        normalTexture=normal)


def _normal_maps(path: Path) -> dict[int, Any]:
    """The file's normal maps by material index, as pyrender textures (our loader does not read them)."""
    import pyrender

    from depthimpostor.scene.gltf_data import GltfData
    from depthimpostor.scene.gltf_file import read_json

    header = read_json(path, str(path))
    data = GltfData(path.resolve(), header, str(path))
    found: dict[int, Any] = {}
    for k, material in enumerate(header.get("materials", [])):
        info = material.get("normalTexture")
        if info is not None:
            pixels = data.image(header["textures"][info["index"]]["source"])
            found[k] = pyrender.Texture(source=np.ascontiguousarray(pixels[..., :3]), source_channels="RGB")
    return found


def render_pyrender(scene: Scene, path: Path, variant: str, renderer: Any) -> tuple[np.ndarray, np.ndarray]:
    """pyrender's view of the same triangles, camera and lights, in linear float, and its depth."""
    import pyrender

    from depthimpostor.scene.gltf_file import read_json

    header = read_json(path, str(path))
    materials = header.get("materials", [])
    normals = _normal_maps(path)
    world = pyrender.Scene(bg_color=[0.0, 0.0, 0.0, 0.0], ambient_light=[0.0, 0.0, 0.0])
    for geometry in scene_geometry(scene.objects):
        obj, mesh = geometry.object, geometry.world_mesh
        index = obj.origin.material if obj.origin is not None else None
        header_material = dict(materials[index]) if index is not None else None
        if header_material is not None and index in normals:
            header_material["_normal"] = normals[index]
        material = _material(obj.material, header_material, variant)
        texture = getattr(obj.material, "texture", None)
        uvs = _uvs(mesh.uvs, texture) if mesh.uvs is not None else None
        # Our tangents where a normal map reads them (the file's, or generated): read by the
        # Appendix B shader alone (APPENDIX_B: pyrender's own never reads them).
        tangents = np.asarray(mesh.tangents, np.float32) if mesh.tangents is not None else None
        primitive = pyrender.Primitive(positions=np.asarray(mesh.positions, np.float32),
                                       normals=np.asarray(mesh.normals, np.float32), tangents=tangents,
                                       texcoord_0=uvs, indices=np.asarray(mesh.indices, np.uint32),
                                       material=material)
        world.add(pyrender.Mesh([primitive]))
    camera = scene.camera
    eye, target, up = (np.asarray(v, np.float64) for v in (camera.eye, camera.target, camera.up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, np.cross(back, right), back, eye
    radius = max(float(np.linalg.norm(g.bounding_sphere[0] - eye)) + g.bounding_sphere[1]
                 for g in scene_geometry(scene.objects))
    world.add(pyrender.PerspectiveCamera(yfov=math.radians(camera.fov_y), aspectRatio=SIZE[0] / SIZE[1],
                                         znear=radius * 1e-4, zfar=radius * 2.0), pose=pose)
    for light in LIGHTS:
        travel = np.asarray(light.direction, np.float64)
        z = -travel / np.linalg.norm(travel)  # pyrender's light shines down its pose's -Z
        x = np.cross((0.0, 1.0, 0.0), z)
        x /= np.linalg.norm(x)
        light_pose = np.eye(4)
        light_pose[:3, 0], light_pose[:3, 1], light_pose[:3, 2] = x, np.cross(z, x), z
        world.add(pyrender.DirectionalLight(color=light.color, intensity=math.pi * light.intensity / HEADROOM),
                  pose=light_pose)
    colour, depth = renderer.render(world)
    return (colour.astype(np.float64) / 255.0) ** 2.2 * HEADROOM, depth


#: pyrender's BRDF made Appendix B's (its shader is copied and these lines replaced).
APPENDIX_B = (
    ("    float r = info.roughness + 1.0;\n    float k = r * r  / 8.0;\n"
     "    float g1 = info.nv / (info.nv * (1.0 - k) + k);\n    float g2 = info.nl / (info.nl * (1.0 - k) + k);\n",
     "    float a2 = pow(info.roughness, 4.0);\n"
     "    float g1 = info.nv + sqrt(a2 + (1.0 - a2) * info.nv * info.nv);\n"
     "    float g2 = info.nl + sqrt(a2 + (1.0 - a2) * info.nl * info.nl);\n"
     "    return 4.0 * info.nl * info.nv / (g1 * g2);\n"),
    ("vec3 spec_contrib = F * G * D / (4.0 * nl * nv + 0.001);", "vec3 spec_contrib = F * G * D / (4.0 * nl * nv);"),
    ("base_color.rgb * (1 - min_roughness), 1.0 - metallic)", "base_color.rgb, 1.0 - metallic)"),
    # Appendix B has no floor; ours evaluates the lights' lobe at MIN_ROUGHNESS at least (a delta
    # light's highlight on a roughness of 0 is 0 / 0), and so does this shader.
    ("roughness = clamp(roughness, min_roughness, 1.0);", f"roughness = clamp(roughness, {MIN_ROUGHNESS!r}, 1.0);"),
    # Colour textures filtered in linear light (handed over decoded: _pyrender_texture), not decoded
    # after filtering their sRGB values.
    ("#ifndef SRGB_CORRECTED", "#ifdef SRGB_DECODED_BEFORE_FILTERING"),
    # The vertex tangents where the primitive has them (glTF's frame, bitangent w N x T): pyrender's
    # shader tests HAS_TANGENTS, which pyrender never defines, so it always builds its frame from
    # screen-space UV derivatives with the bitangent N x T, wrong where the UVs are mirrored.
    ("#ifndef HAS_TANGENTS", "#ifndef TANGENT_LOC"),
)


def appendix_b_shaders() -> Path:
    import pyrender

    source = Path(pyrender.__file__).parent / "shaders"
    folder = Path(tempfile.mkdtemp(prefix="pyrender_appendix_b_"))
    shutil.copytree(source, folder, dirs_exist_ok=True)
    text = (folder / "mesh.frag").read_text()
    for old, new in APPENDIX_B:
        if old not in text:
            raise SystemExit(f"pyrender's mesh.frag has changed: {old!r} not found")
        text = text.replace(old, new)
    (folder / "mesh.frag").write_text(text)
    return folder


def difference_picture(ours: np.ndarray, theirs: np.ndarray, appendix_b: np.ndarray, path: Path) -> None:
    """Ours | pyrender (same inputs) | their difference x 4 | the difference to Appendix B's x 4."""
    from depthimpostor.colour import display_encode

    def difference(other: np.ndarray) -> np.ndarray:  # per channel, clamped as measured
        return (np.clip(np.abs(np.clip(ours, 0.0, 1.0) - np.clip(other, 0.0, 1.0)) * 4.0, 0.0, 1.0) * 255).astype(np.uint8)

    strip = np.concatenate([display_encode(ours), display_encode(theirs), difference(theirs), difference(appendix_b)], axis=1)
    Image.fromarray(strip).save(path, optimize=True)


def edges(depth: np.ndarray) -> np.ndarray:
    """Pixels within one of a silhouette (a depth step of over EDGE_STEP, or the background's
    border): pyrender draws with 4x multisampling, which it does not let one turn off, and ours
    with one sample a pixel, so there the two differ by design."""
    far = np.where(depth > 0, depth, np.inf)
    step = np.zeros(depth.shape, bool)
    for axis in (0, 1):
        a, b = np.swapaxes(far, 0, axis)[:-1], np.swapaxes(far, 0, axis)[1:]
        with np.errstate(invalid="ignore"):
            jump = (np.isfinite(a) | np.isfinite(b)) & ~(np.abs(a - b) <= EDGE_STEP * np.minimum(a, b))
        np.swapaxes(step, 0, axis)[:-1] |= jump
        np.swapaxes(step, 0, axis)[1:] |= jump
    grown = step.copy()
    for axis in (0, 1):
        for shift in (-1, 1):
            grown |= np.roll(step, shift, axis=axis)
    return grown


def figures(ours: np.ndarray, theirs: np.ndarray, edge: np.ndarray) -> tuple[float, float, int]:
    """RMSE and the share of pixels off by more than DIFFERS, over the pixels either side covers
    away from silhouettes, and their count."""
    covered = ((ours.max(axis=2) > 0) | (theirs.max(axis=2) > 0)) & ~edge
    if not covered.any():
        return 0.0, 0.0, 0
    # Clamped to [0, 1] as `compare` measures (oracles/compare.py COLOUR_SPACE): a delta light's
    # highlight on a polished metal reaches hundreds, and its exact peak is no part of what is seen.
    error = np.clip(ours[covered], 0.0, 1.0) - np.clip(theirs[covered], 0.0, 1.0)
    return (float(np.sqrt((error ** 2).mean())), float((np.abs(error).max(axis=1) > DIFFERS).mean()),
            int(covered.sum()))


#: Every remaining difference, explained (written from the pictures; the table above it is measured).
EXPLAINED = """
## What the differences are

Read the columns left to right: each takes one cause out.

**as written -> same inputs: what our loader does not implement.** Both columns now hand pyrender
what our loader reads, normal maps and BLEND included, so they differ only where our loader lists
something as ignored: ClearCoatTest's KHR_materials_clearcoat, which pyrender does not read either
(equal columns). Both sides take the file's doubleSided: a single-sided material's back faces are
culled by both (pyrender's GL_CULL_FACE, ours: docs/scene_format.md, "Faces").

**same inputs -> Appendix B: where pyrender departs from the glTF specification.** pyrender's
shader (pyrender/shaders/mesh.frag in pyrender 0.1.45) has Schlick-GGX geometry on
k = (r + 1)^2 / 8 of the *perceptual* roughness (UE4's remap for analytic lights) instead of Appendix
B's height-correlated Smith visibility on alpha = r^2; a diffuse colour darkened by a further 4 %
(`base * (1 - 0.04) * (1 - metallic)`, the spec: `base * (1 - metallic)`, less the Fresnel term);
a floor of 0.04 on roughness (ours: 0.0525 for the lights' lobe, MIN_ROUGHNESS, which the column
uses); +0.001 in the specular denominator; it filters sRGB-encoded texels and decodes the result
(the texture is stored as plain RGBA and decoded in the shader), where the specification's sRGB
textures are decoded before filtering (ours: GL_SRGB8_ALPHA8); and it never reads the vertex
tangents (its shader tests HAS_TANGENTS, which pyrender never defines), building the normal map's
frame from screen-space UV derivatives with the bitangent N x T, where glTF's is w N x T: wrong
wherever the UVs are mirrored, which is what NormalTangentMirrorTest tests (0.103 -> 0.011 once
the column's shader reads our tangents and floors roughness as ours does; NormalTangentTest, without
mirrored UVs, 0.024 -> 0.016).
The `Appendix B` column is pyrender with these lines replaced (APPENDIX_B in
tools/independent_compare.py): on the models without creases or detail finer than a pixel (the
boxes, the skins, the morph cube and triangle, the sparse accessor, MorphPrimitivesTest,
BoxTextured, ClearCoatTest) the RMSE drops to 0.001-0.004, the 8-bit gamma-2.2 readback's rounding
at HEADROOM = 4 (an RMS of about 0.003 at a linear 0.5). That is: our shading is the
specification's, and pyrender's is the specification's but for these lines. The texture filtering
term is most of MorphPrimitivesTest's and BoxTextured's difference (a magnified checker and
logo: edges between texels of very different values, where a blend of encoded values is darker than
the blend of light).

**What remains in the Appendix B column.**
- *Anti-aliasing.* pyrender draws into a 4x multisampled buffer and cannot be told not to; ours draws
  one sample a pixel (`render.samples = 1`). Pixels within one of a depth step are left out of the
  figures, but multisampling also blends the two sides of a crease (AnimatedMorphSphere's flat facets,
  DamagedHelmet's panel lines) and of detail thinner than a pixel that is not a depth step of 2 %
  (2CylinderEngine's cooling fins, 17 % of its pixels; BrainStem's cables and fingers, 7.5 %;
  CesiumMilkTruck's window frames and wheels, 2.4 %; NormalTangent*'s small spheres and the normal
  maps' fine relief; MorphStressTest's bar edges). The difference pictures' fourth panel shows
  these as outlines and nothing inside the faces.
- *Mipmaps on minified textures.* TextureTransformTest's marker squares (a few pixels across) differ
  where the two renderers pick and build their mip levels differently (ours: texture arrays, an
  image smaller than its group's layer resampled up in linear light: docs/scene_format.md).
- *Alpha.* AlphaBlendModeTest's three MASK panels (cutoffs 0.25, 0.5, 0.75) are cut away by ours
  and drawn whole by pyrender, whose shader has no alpha test (it takes alphaCutoff and does not use
  it); its BLEND panel is blended by both, ours over the marble wall behind it (the wall shows
  through at the panel's top, where alpha is 0, as glTF's BLEND asks), pyrender's over black (no
  wall shows through it): the column's 19.7 %, pyrender's limitations both.
- *Default material.* SimpleSkin, SimpleMorph and SimpleSparseAccessor have no material: glTF's
  default is a rough white metal (metallic 1, roughness 1), which this comparison showed our loader
  drew as a white *diffuse* material (twice as bright as pyrender); the loader now gives them the
  specification's default (scene/gltf.py GLTF_DEFAULT_MATERIAL, single-sided as glTF's default
  is), and they agree to the readback's rounding.

**Left out of both sides on purpose** (the module docstring): the occlusion map (pyrender darkens
direct light with it; the specification and ours darken the ambient term alone, 0 here), the
ambient/IBL term (pyrender has none that is finished: `USE_IBL` is a TODO in its shader; ours is
`render.ambient`, set to 0, and this comparison would need pyrender's IBL to cover the sky's),
vertex colours (none of these models draws with them) and the emissive factor's square (pyrender
multiplies it in twice; it is handed the factor's square root). Double-sided back faces: ours shades
them turned round (glTF-Sample-Viewer's and three.js's way), pyrender as it shades a front face;
none of these models shows one to this camera (every pixel's first hit on AlphaBlendModeTest,
NormalTangentTest, NormalTangentMirrorTest and MorphStressTest, the double-sided ones, is a front
face: traced with Embree).
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--large", type=Path, default=LARGE)
    parser.add_argument("--models", nargs="*", default=[])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    if os.environ.get("PYOPENGL_PLATFORM") != "egl":
        print("set PYOPENGL_PLATFORM=egl (pyrender's headless context)", file=sys.stderr)
        return 2
    models: list[PublicModel] = [m for m in CATALOGUE if (not args.models or m.name in args.models)
                                 and model_path(m, args.large).is_file()]
    scenes = {m.name: our_scene(model_path(m, args.large)) for m in models}
    ours = render_ours(scenes)
    import pyrender

    pictures = args.out.with_suffix("")
    pictures.mkdir(parents=True, exist_ok=True)
    rows = []
    variants = ("as written", "same inputs", "Appendix B")
    renderer = pyrender.OffscreenRenderer(*SIZE)
    patched = pyrender.shader_program.ShaderProgramCache(shader_dir=str(appendix_b_shaders()))
    for model in models:
        scene, path = scenes[model.name], model_path(model, args.large)
        row = []
        edge = np.zeros(SIZE[::-1], bool)
        drawn = {}
        for variant in variants:
            if variant == "Appendix B":
                renderer._renderer._program_cache = patched  # its programs, from the patched shaders
            theirs, depth = render_pyrender(scene, path, variant, renderer)
            if variant == "as written":
                edge = edges(depth)
            row.append(figures(ours[model.name], theirs, edge))
            drawn[variant] = theirs
        difference_picture(ours[model.name], drawn["same inputs"], drawn["Appendix B"], pictures / f"{model.name}.png")
        renderer.delete()
        renderer = pyrender.OffscreenRenderer(*SIZE)  # a fresh program cache: pyrender's own shaders
        ignored = [n for _, names in ignored_in_files(scene) for n in names]
        rows.append((model, row, ignored, row[0][2], int(edge.sum())))
        print(model.name, [f"{rmse:.4f} {100 * share:.1f}%" for rmse, share, _ in row], flush=True)
    renderer.delete()
    lines = ["# Our direct view against pyrender, per pixel", "",
             "Written by `tools/independent_compare.py` (its docstring says why pyrender and what each column "
             f"takes out): {SIZE[0]}x{SIZE[1]}, time 0, two directional lights, no ambient, black background, "
             "linear colour clamped to [0, 1] (as `compare` measures) over the pixels either side covers, less those "
             "within a pixel of a silhouette (pyrender draws with 4x multisampling, which it cannot turn off). Each cell: RMSE, and the share of those pixels "
             f"off by more than {DIFFERS} in a channel. independent/<model>.png: ours | pyrender (same inputs) | "
             "|difference| x 4 | |difference to pyrender made Appendix B's| x 4.", "",
             "| model | pixels | silhouette pixels (left out) | as written | same inputs | Appendix B | ignored by our loader |",
             "|---|---:|---:|---:|---:|---:|---|"]
    for model, row, ignored, pixels, edge_pixels in rows:
        cells = " | ".join(f"{rmse:.4f}, {100 * share:.1f} %" for rmse, share, _ in row)
        lines.append(f"| {model.name} | {pixels:,} | {edge_pixels:,} | {cells} | {', '.join(ignored) or 'nothing'} |")
    args.out.write_text("\n".join(lines) + "\n" + EXPLAINED)
    print(f"wrote {args.out} and {pictures}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
