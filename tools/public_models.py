"""Public glTF sample models beside mirrors (issue 33): each model of CATALOGUE placed before a mirror
wall and beside a mirror sphere, lit by one directional light, rendered by every method and compared
with the Embree truth (traced once per model). Writes results/llvmpipe/public_models.md: per model,
what the loader lists as ignored, wrong object and colour RMSE for `hybrid` and `raytrace`, the
depth method's wrong-surface share, and every method's figures.

    PYTHONPATH=$PWD python3 tools/public_models.py fetch      # the large models, into --large
    PYTHONPATH=$PWD python3 tools/public_models.py run        # the table

The small models are committed under tests/data/gltf/ (5 MB in all); the large ones are downloaded
by `fetch` from the pinned commits below (raw.githubusercontent.com, each file's SHA-256 checked)
into `--large` (default ~/.cache/depthimpostor/public_models); a large model that is not there is
left out of the table, which says so. docs/public_models.md lists each with its source and licence.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import sys
import time
import urllib.request
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from depthimpostor.constants import Method
from depthimpostor.errors import DepthImpostorError, SceneWarning
from depthimpostor.oracles.compare import Comparison, TruthFrame, compare
from depthimpostor.plan import ignored_in_files
from depthimpostor.renderer import Renderer
from depthimpostor.scene import Scene
from depthimpostor.scene.gltf import read_gltf
from depthimpostor.scene.loader import parse_scene

ROOT = Path(__file__).resolve().parent.parent
COMMITTED = ROOT / "tests" / "data" / "gltf"
LARGE = Path.home() / ".cache" / "depthimpostor" / "public_models"
OUT = ROOT / "results" / "llvmpipe" / "public_models.md"

# The repositories the files were taken from, at the commits they were taken at.
RGL2GLTF = ("dmurdoch/rgl2gltf", "890db2a94f440f1b8b4d0880ebda663418f3a9af")
TRIMESH = ("mikedh/trimesh", "a513c0e2cfa6dfbd3121a6dfd8ceb002b9ef55d8")
ASSIMP = ("assimp/assimp", "21bea12f1278090c09a94c39ca090d9fb458ccd9")


@dataclass(frozen=True)
class PublicModel:
    name: str
    file: str  # the glTF file, relative to COMMITTED (committed) or to the large models' folder
    source: tuple[str, str]  # (repository, commit)
    folder: str  # where the file (and any .bin and images beside it) lies in that repository
    licence: str
    features: str  # what it exercises
    committed: bool = True
    large_files: tuple[tuple[str, str], ...] = ()  # not committed: (file, SHA-256) to download

    @property
    def url(self) -> str:
        return f"https://github.com/{self.source[0]}/tree/{self.source[1][:7]}/{self.folder}"


CC_BY = "CC BY 4.0"
CC0 = "CC0 1.0"
CESIUM = "CC BY 4.0, with Cesium's trademark notice (Khronos' LicenseRef-CC-BY-TM)"

CATALOGUE: tuple[PublicModel, ...] = (
    PublicModel("BoxAnimated", "BoxAnimated.glb", RGL2GLTF, "inst/localtests", CC_BY + " (Cesium)",
                "node rotation and translation channels of different lengths (LINEAR)"),
    PublicModel("RiggedSimple", "RiggedSimple.glb", RGL2GLTF, "inst/glb", CC_BY + " (Cesium)",
                "a skin of two joints, animated (LINEAR TRS), MAT4 inverse bind matrices"),
    PublicModel("SimpleSkin", "SimpleSkin/simple_skin.gltf", ASSIMP, "test/models/glTF2/simple_skin", CC0,
                "a skin of two joints animated by rotation, data URIs"),
    PublicModel("AnimatedMorphCube", "AnimatedMorphCube/AnimatedMorphCube.gltf", ASSIMP,
                "test/models/glTF2/AnimatedMorphCube/glTF", CC0, "two morph targets, weights animated"),
    PublicModel("AnimatedMorphSphere", "AnimatedMorphSphere/AnimatedMorphSphere.gltf", ASSIMP,
                "test/models/glTF2/AnimatedMorphSphere/glTF", CC0, "two morph targets on a sphere of 960 triangles, animated"),
    PublicModel("SimpleMorph", "SimpleMorph/SimpleMorph.gltf", ASSIMP, "test/models/glTF2/SimpleMorph/glTF", CC0,
                "morph targets on a triangle, default weights, animated; no material (glTF's default)"),
    PublicModel("MorphPrimitivesTest", "MorphPrimitivesTest/MorphPrimitivesTest.gltf", ASSIMP,
                "test/models/glTF2/MorphPrimitivesTest/glTF", CC_BY + " (ft-lab)",
                "a morph target shared by two primitives of one mesh, mesh weights, a base colour texture (JPEG)"),
    PublicModel("TextureTransformTest", "TextureTransformTest/TextureTransformTest.gltf", ASSIMP,
                "test/models/glTF2/textureTransform", CC0 + " (Microsoft)",
                "KHR_texture_transform: offset, rotation, scale and all three"),
    PublicModel("SimpleSparseAccessor", "SimpleSparseAccessor/SimpleSparseAccessor.gltf", RGL2GLTF, "inst/localtests",
                CC_BY, "a sparse accessor displacing positions"),
    PublicModel("BoxTextured", "BoxTextured.glb", ASSIMP, "test/models/glTF2/BoxTextured-glTF-Binary", CESIUM,
                "a base colour texture (PNG), a sampler"),
    PublicModel("BoxInterleaved", "BoxInterleaved.glb", TRIMESH, "models", CC_BY + " (Cesium)",
                "interleaved vertex attributes (byteStride)"),
    PublicModel("CesiumMilkTruck", "CesiumMilkTruck.glb", TRIMESH, "models", CESIUM,
                "a textured truck, its wheels turned by a node animation"),
    PublicModel("ClearCoatTest", "ClearCoatTest/ClearCoatTest.gltf", ASSIMP, "test/models/glTF2/ClearCoat-glTF",
                CC_BY + " (Analytical Graphics)",
                "KHR_materials_clearcoat, alphaMode BLEND labels, normal maps, emissive texture"),
    PublicModel("AlphaBlendModeTest", "AlphaBlendModeTest.glb", RGL2GLTF, "inst/localtests",
                CC_BY + " (Analytical Graphics)",
                "alphaMode MASK at cutoffs 0.25, 0.5, 0.75, alphaMode BLEND and OPAQUE side by side; ORM and normal maps"),
    PublicModel("DamagedHelmet", "DamagedHelmet.glb", RGL2GLTF, "inst/localtests",
                "CC BY 4.0 and CC BY-NC 4.0 (Khronos' listing; theblueturtle_, ctxwing)",
                "every texture map: base colour, metallic-roughness, normal, occlusion, emissive", False,
                (("DamagedHelmet.glb", "a1e3b04de97b11de564ce6e53b95f02954a297f0008183ac63a4f5974f6b32d8"),)),
    PublicModel("BrainStem", "BrainStem.glb", RGL2GLTF, "inst/localtests",
                "Poser EULA (Smith Micro Software; Khronos' LicenseRef-Poser-EULA)",
                "a figure of 59 skinned parts on one skin of 18 joints, animated", False,
                (("BrainStem.glb", "ddda3a53b5c9771f992463034a430340ba2bac571e5869c723f7cba4976e9174"),)),
    PublicModel("2CylinderEngine", "2CylinderEngine.glb", RGL2GLTF, "inst/localtests",
                CC_BY + " (Khronos' listing's default)", "115 parts under a deep node tree, a camera", False,
                (("2CylinderEngine.glb", "bb5fbccc73a3f68c52f26687fbb25b4a1248ab5f8a115ec55e7ac6a4451c47ee"),)),
    PublicModel("NormalTangentTest", "NormalTangentTest.glb", RGL2GLTF, "inst/localtests",
                "CC BY 4.0 (its asset.copyright; Khronos' listing says CC0 1.0)",
                "normal maps without tangents; metallic-roughness and occlusion maps", False,
                (("NormalTangentTest.glb", "4476f994b8789e0130313f8b24908f50b492bd3df9bfca258bad59c142955281"),)),
    PublicModel("NormalTangentMirrorTest", "NormalTangentMirrorTest.glb", RGL2GLTF, "inst/localtests",
                CC_BY + " (Analytical Graphics)", "normal maps with mirrored UVs and tangents", False,
                (("NormalTangentMirrorTest.glb", "705465c5045c113c680be8631e9295db8fe8e6342b0e5f9b094b89d33d9bb12a"),)),
    PublicModel("Duck", "Duck.glb", TRIMESH, "models", "SCEA Shared Source License 1.0 (Sony)",
                "a textured duck; a camera", False,
                (("Duck.glb", "65bf938f54d6073e619e76e007820bbf980cdc3dc0daec0d94830ffc4ae54ab5"),)),
    PublicModel("MorphStressTest", "MorphStressTest/MorphStressTest.gltf", ASSIMP,
                "test/models/glTF2/MorphStressTest/glTF", CC_BY + " (Analytical Graphics)",
                "eight morph targets, three animations, an occlusion map on TEXCOORD_1", False,
                (("MorphStressTest.gltf", "e9ffb5c8d4d6b8b83bf0bbee26146addcd474a44294bcbaae8019e63767272cd"),
                 ("MorphStressTest.bin", "684397e52a7f3941f369a88373633050462b6c27c1f1aff05f5bb32cf09cabe6"),
                 ("Base_AO.png", "e64d4f4b3d7b4f1a0fa3e37006a8fbab76b8980d72fd740060631c30d8d77681"),
                 ("ColorSwatches.png", "80ac40f4caa24872aef11a2990afcaaec7fe9e3113db148ecf63f0016639e9fb"),
                 ("TinyGrid.png", "16af23fd3e1bc37c8989293a09ee456c4f19825db69a9266c267e8035937c834"))),
)

#: Frame size of the table's renders: the truth traces every mirror pixel on the CPU, for 21 models.
SIZE = (320, 200)
#: Where the model stands (the centre of its bounding sphere) and that sphere's radius once scaled.
MODEL_CENTRE, MODEL_RADIUS = (-0.35, 0.55, 0.0), 0.5


def model_path(model: PublicModel, large: Path) -> Path:
    return (COMMITTED if model.committed else large) / model.file


def mirror_scene(path: Path, size: tuple[int, int] = SIZE, ambient: float = 0.15) -> Scene:
    """The file scaled into a sphere of MODEL_RADIUS at MODEL_CENTRE (its bounds at time 0), on a
    checker floor, before a mirror wall and beside a mirror sphere, lit by one directional light."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)  # plan's ignored list says the same
        centre, radius = read_gltf(path, str(path)).bounds()
    scale = MODEL_RADIUS / max(radius, 1e-9)
    position = [c - scale * float(x) for c, x in zip(MODEL_CENTRE, centre, strict=True)]
    data: dict[str, Any] = {
        "render": {"size": list(size), "ambient": ambient},
        "camera": {"eye": [0.45, 1.25, 3.1], "target": [0.0, 0.6, -0.4], "fov_y": 45.0},
        "lights": [{"type": "directional", "direction": [-0.4, -1.0, -0.5]}],
        "objects": [
            {"name": "floor", "shape": {"type": "plane", "size": [6.0, 6.0]},
             "material": {"type": "checker", "color_a": [0.8, 0.8, 0.8], "color_b": [0.3, 0.3, 0.35], "scale": 2.0}},
            {"name": "wall mirror", "shape": {"type": "plane", "size": [3.6, 2.2]},
             "material": {"type": "mirror", "tint": [0.95, 0.95, 0.95]},
             "position": [0.0, 1.1, -1.0], "rotation": [90.0, 0.0, 0.0]},
            {"name": "sphere mirror", "shape": {"type": "sphere", "radius": 0.42},
             "material": {"type": "mirror", "tint": [0.95, 0.95, 0.95]}, "position": [0.75, 0.42, 0.15]},
            {"name": "model", "shape": {"type": "gltf", "path": path.name}, "position": position, "scale": scale},
        ],
    }
    return parse_scene(data, f"{path.name} beside mirrors", path.parent)


def ignored(scene: Scene) -> tuple[str, ...]:
    """What `plan` lists as ignored in the scene's one glTF file."""
    names = [name for _, listed in ignored_in_files(scene) for name in listed]
    return tuple(names)


def run_model(ctx: Any, scene: Scene) -> dict[Method, Comparison | str]:
    """Every method's comparison with the truth (traced once), or the one line that refused it."""
    results: dict[Method, Comparison | str] = {}
    truth: TruthFrame | None = None
    for method in Method:
        try:
            with Renderer(ctx, scene, method=method, reflection_data=True) as renderer:
                renderer.render()
                results[method] = compare(renderer, truth)
                truth = results[method].truth_frame  # type: ignore[union-attr]
        except DepthImpostorError as error:
            results[method] = str(error).splitlines()[0]
    return results


def _cells(result: Comparison | str, wrong_surface: bool = False) -> str:
    if isinstance(result, str):
        return "refused"
    f = result.figures
    if wrong_surface:
        return f"{100 * f.wrong_surface_share:.2f} %"
    wrong = round(f.wrong_object_share * f.mirror_pixels)
    return f"{100 * f.wrong_object_share:.2f} % ({wrong} px) / {f.color_rmse:.1e}"


#: What the one wrong pixel of every model is (read from `compare`'s worst pixels).
WRONG_PIXEL = ("The one wrong-object pixel of `hybrid` and `raytrace` (0.004 % of the mirror pixels, shown as 0.00 %) "
               "is the scene's, not the model's: the sphere mirror's reflection of the checker floor's far edge, where "
               "the shader's float32 ray meets the floor plane within rounding of its boundary and the float64 truth "
               "passes it by into the sky. It alone makes their colour RMSE of 3e-4 (an error of 0.06 at one pixel "
               "in 26,000); no other mirror pixel is off by more than 1e-3 of its luminance (checked on BoxInterleaved "
               "and DamagedHelmet, whose sun highlight of 67 differs by 0.02). DamagedHelmet's `hybrid` had two more "
               "helmet pixels, on the right object, off by 0.056 and 0.085 (pixels (82, 162) in the wall mirror and "
               "(121, 186) in the sphere; tools/helmet_pixels.py lists any such pixel): there the ray's first triangle "
               "(3790 at t = 0.78283; 9233 at t = 0.59269), a sliver where the helmet's shell folds, seen almost "
               "edge-on from the mirror's centre, is in no sample of the 3 x 3 window around the images' hit, and the "
               "hybrid made the hit exact on the triangle behind it that the window shows (10953 at 0.79004; 9374 at "
               "0.59418). That point is hidden from the mirror's centre by another triangle the window shows (3706; "
               "9234): the image does not hold it, and since lib/reflected_scene.glsl's hidden_from_eye says so, "
               "the hybrid traces such a ray (518 re-traced rays instead of 516 on this scene), and both pixels are "
               "`raytrace`'s.")

#: The other figures that are not the scene's one pixel, each checked.
OTHER_DIFFERENCES = (
    "ClearCoatTest's `hybrid` and `raytrace` RMSE of 5.3e-3 is the eye's, not the reflection's: 69 of the 70 "
    "mirror pixels off by more than 1e-3 (the 70th is the floor's far edge above) are among the 74 that the eye "
    "sees through the blended R1_CoatOnlySample (alphaMode BLEND, a textured alpha, roughness 0.03), where the eye's "
    "transparent pass blends its rasterized surface (mipmapped texels at the fragment) over the mirror and the "
    "truth composites its exact eye ray through the pixel's centre (level 0): the difference scene_format.md's "
    "Transparency section measures for the stained-glass pane (before doubleSided was read: 5.9e-3, at the "
    "same pixels).\n\n"
    "Since glTF's doubleSided is read (docs/scene_format.md, \"Faces\"), a single-sided surface seen from "
    "behind is not there for the truth and every method alike. SimpleMorph is one triangle with glTF's default "
    "material (single-sided) facing the camera: the wall mirror, which sees its back, shows none of it (409 "
    "pixels when both faces were drawn as the front), so the depth method's wrong-surface share is over the "
    "sphere mirror's 25 pixels of it alone (7.41 %; 2.48 % with both faces). SimpleSkin and SimpleSparseAccessor "
    "have no material either, and face the camera too: the wall mirror shows none of them (729 and 419 pixels "
    "with both faces), and the depth method's share is over the sphere's 44 and 34 pixels (0.00 % and 2.86 %; "
    "0.13 % and 1.74 % with both faces); every method's figures on these three moved for that reason.")


def report(rows: list[tuple[PublicModel, Scene, dict[Method, Comparison | str], float]], missing: list[PublicModel],
           refusals: list[str]) -> str:
    lines = ["# Public glTF sample models beside mirrors", "",
             f"Written by `tools/public_models.py run` on llvmpipe: each model of docs/public_models.md scaled into "
             f"a sphere of radius {MODEL_RADIUS} before a mirror wall and beside a mirror sphere, one directional "
             f"light, frames of {SIZE[0]}x{SIZE[1]} at time 0, every method compared with the Embree truth over the "
             "mirror pixels (`compare`'s figures: colour RMSE in linear space, docs/colour.md). "
             "*Wrong object*: the share of mirror pixels whose reflected ray hit another object than the truth's; "
             "*wrong surface*: of the mirror pixels showing a reflected object, the share showing another object "
             "or a colour off by more than 0.1. public_models.png shows each model's `hybrid` frame.", "",
             "| model | triangles (and rectangles drawn as planes) | mirror pixels | `hybrid` wrong object / RMSE | `raytrace` wrong object / RMSE | "
             "`depth` wrong surface | `depth` RMSE | ignored (plan) |",
             "|---|---:|---:|---:|---:|---:|---:|---|"]
    for model, scene, results, _ in rows:
        depth = results[Method.DEPTH]
        first = next((r for r in results.values() if not isinstance(r, str)), None)
        pixels = first.figures.mirror_pixels if first is not None else 0
        parts = [o for o in scene.objects if o.origin is not None]  # the model's: placed from its file
        triangles = sum(len(o.shape.mesh.indices) for o in parts if hasattr(o.shape, "mesh"))
        planes = sum(not hasattr(o.shape, "mesh") for o in parts)  # rectangles loaded as planes
        shown = f"{triangles:,}" + (f" + {planes} planes" if planes else "")
        lines.append(f"| {model.name} | {shown} | {pixels:,} | {_cells(results[Method.HYBRID])} | "
                     f"{_cells(results[Method.RAYTRACE])} | {_cells(depth, True)} | "
                     f"{'refused' if isinstance(depth, str) else f'{depth.figures.color_rmse:.4f}'} | "
                     f"{', '.join(ignored(scene)) or 'nothing'} |")
    lines += ["", "## Every method: wrong surface, colour RMSE", "",
              "| model | " + " | ".join(f"`{m.option}`" for m in Method) + " | seconds |",
              "|---|" + "---:|" * (len(Method) + 1)]
    for model, _, results, seconds in rows:
        cells = []
        for method in Method:
            result = results[method]
            cells.append("refused" if isinstance(result, str) else
                         f"{100 * result.figures.wrong_surface_share:.1f} %, {result.figures.color_rmse:.3f}")
        lines.append(f"| {model.name} | " + " | ".join(cells) + f" | {seconds:.0f} |")
    if refusals:
        lines += ["", "Refusals (one line each, as the command line gives them):", ""]
        lines += [f"- {line}" for line in sorted(set(refusals))]
    lines += ["", WRONG_PIXEL, "", OTHER_DIFFERENCES]
    if missing:
        lines += ["", "Left out (not downloaded: `tools/public_models.py fetch`): "
                  + ", ".join(m.name for m in missing) + "."]
    return "\n".join(lines) + "\n"


def fetch(large: Path) -> int:
    """Download the large models from their pinned commits, each file's SHA-256 checked."""
    for model in CATALOGUE:
        for name, digest in model.large_files:
            target = large / Path(model.file).parent / name
            if target.is_file() and hashlib.sha256(target.read_bytes()).hexdigest() == digest:
                continue
            repo, commit = model.source
            url = f"https://raw.githubusercontent.com/{repo}/{commit}/{model.folder}/{name}"
            print(f"fetching {url}", flush=True)
            with urllib.request.urlopen(url, timeout=120) as response:  # noqa: S310 (a fixed https URL)
                data = response.read()
            if hashlib.sha256(data).hexdigest() != digest:
                print(f"{url}: SHA-256 differs from the pinned one; not written", file=sys.stderr)
                return 1
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
    return 0


def contact_sheet(rows: list[tuple[PublicModel, Scene, dict[Method, Comparison | str], float]], path: Path) -> None:
    """Each model's `hybrid` frame at half size, named, four to a row: to look at."""
    from PIL import Image, ImageDraw

    from depthimpostor.colour import display_encode

    tiles = []
    for model, _, results, _ in rows:
        result = results[Method.HYBRID]
        if isinstance(result, str):
            continue
        tile = Image.fromarray(display_encode(result.render, *result.display)).resize((SIZE[0] // 2, SIZE[1] // 2))
        ImageDraw.Draw(tile).text((3, 2), model.name, fill=(255, 255, 0))
        tiles.append(tile)
    if not tiles:
        return
    columns = 4
    sheet = Image.new("RGB", (columns * SIZE[0] // 2, -(-len(tiles) // columns) * SIZE[1] // 2))
    for k, tile in enumerate(tiles):
        sheet.paste(tile, ((k % columns) * SIZE[0] // 2, (k // columns) * SIZE[1] // 2))
    sheet.save(path)


def run(large: Path, names: list[str], out: Path) -> int:
    from depthimpostor.gpu.context import create_context

    ctx = create_context()
    rows, missing, refusals = [], [], []
    for model in CATALOGUE:
        if names and model.name not in names:
            continue
        path = model_path(model, large)
        if not path.is_file():
            missing.append(model)
            continue
        start = time.perf_counter()
        scene = mirror_scene(path)
        results = run_model(ctx, scene)
        seconds = time.perf_counter() - start
        refusals += [f"`{m.option}` on {model.name}: {r}" for m, r in results.items() if isinstance(r, str)]
        rows.append((model, scene, results, seconds))
        hybrid, raytrace = results[Method.HYBRID], results[Method.RAYTRACE]
        print(model.name, _cells(hybrid), _cells(raytrace), _cells(results[Method.DEPTH], True),
              f"{seconds:.0f} s", flush=True)
    out.write_text(report(rows, missing, refusals))
    contact_sheet(rows, out.with_suffix(".png"))
    print(f"wrote {out} and {out.with_suffix('.png')}")
    worst = [r.figures.wrong_object_share for _, _, results, _ in rows
             for m, r in results.items() if m in (Method.HYBRID, Method.RAYTRACE) and not isinstance(r, str)]
    return 0 if all(math.isclose(w, 0.0) for w in worst) else 1


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=("fetch", "run"))
    parser.add_argument("--large", type=Path, default=LARGE, help="the folder of the large (downloaded) models")
    parser.add_argument("--models", nargs="*", default=[], help="these models alone (names as in the catalogue)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    return fetch(args.large) if args.command == "fetch" else run(args.large, args.models, args.out)


if __name__ == "__main__":
    raise SystemExit(main())
