"""The bindings table (depthimpostor/gpu/bindings.py) is the only place a texture unit or block binding is
chosen: every number is unique within its kind (enum.unique), no module outside the table binds a
literal, and the compute shader's layout qualifiers come from it."""

from __future__ import annotations

import re
from pathlib import Path

from depthimpostor.gpu.bindings import ImageUnit, StorageBuffer, TextureUnit, UniformBlock, glsl_bindings
from depthimpostor.constants import MATERIAL_ARRAYS, glsl_constants
from depthimpostor.gpu.textures import array_unit

PACKAGE = Path(__file__).resolve().parent.parent / "depthimpostor"
SHADERS = Path(__file__).resolve().parent.parent / "shaders"

# A GL call that takes a unit or binding, given a number literal instead of the table's name.
LITERAL_BINDING = re.compile(r"(\.use|bind_to_uniform_block|bind_to_storage_buffer|bind_to_image|bind_texture\([^)]*,)"
                             r"\(?\s*\d+\s*[,)]")


def test_every_unit_and_binding_fits_the_gl_minimums() -> None:
    # GL 3.3 guarantees 48 texture units in all (GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS: what a unit's
    # number must stay under), 16 samplers in one fragment shader (the mirror shader samples at most
    # every unit but the viewer's own two, the diffuse pass's mipmapped material texture arrays, whose
    # level 0 it reads from MATERIAL_TEXELS, and the ray query's rays, which its shader reads in
    # place of the deferred pass's surfaces, and the planar and SSR methods' screen textures, which
    # their variants read in place of the depth images' and the BVH's) and 12 uniform blocks; GL 4.3
    # 8 storage buffers and 8 image units a compute shader.
    diffuse_only = tuple(unit for unit in TextureUnit if unit.name.startswith("MATERIAL_ARRAY"))
    ray_query_only = (TextureUnit.RAY_ORIGINS, TextureUnit.RAY_DIRECTIONS)
    screen_only = (TextureUnit.SCREEN_COLOR, TextureUnit.SCREEN_SURFACE, TextureUnit.SSR_PYRAMID)
    # The sky's mipmapped image, read by its prefilter alone (once per sky, before the frame).
    prefilter_only = (TextureUnit.ENVIRONMENT_SOURCE,)
    shader_units = [unit for unit in TextureUnit
                    if unit not in (TextureUnit.FRAME, TextureUnit.GLYPHS, *diffuse_only, *ray_query_only,
                                     *screen_only, *prefilter_only)]
    # A glossy mirror's colour mips are read by the methods that bake images and trace no triangles
    # (plan.py's _builds_colour_mips): never with the BVH's units or the hybrid method's.
    triangles_only = (TextureUnit.BVH_NODES, TextureUnit.BVH_TRIANGLES, TextureUnit.BVH_PLACES,
                      TextureUnit.TRIANGLE_IDS, TextureUnit.IMPOSTOR_BEYOND)
    sharp = [unit for unit in shader_units if unit != TextureUnit.COLOUR_MIPS]
    glossy = [unit for unit in shader_units if unit not in triangles_only]
    assert max(TextureUnit) < 48 and len(sharp) <= 16 and len(glossy) <= 16
    assert max(UniformBlock) < 12
    # The diffuse pass: every texture array on its two samplers, the shadow maps and the environment.
    assert len(diffuse_only) == 2 * MATERIAL_ARRAYS and len(diffuse_only) + 2 <= 16
    assert [array_unit(k, clamped) for clamped in (False, True) for k in range(MATERIAL_ARRAYS)] == list(diffuse_only)
    assert max(StorageBuffer) < 8 and max(ImageUnit) < 8


def test_no_module_binds_a_literal_unit() -> None:
    offenders = [f"{path.relative_to(PACKAGE)}:{number}: {line.strip()}"
                 for path in PACKAGE.rglob("*.py") if path.relative_to(PACKAGE).as_posix() != "gpu/bindings.py"
                 for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if LITERAL_BINDING.search(line)]
    assert not offenders, offenders


def test_shaders_name_their_bindings_from_the_table() -> None:
    assert set(glsl_bindings()) <= set(glsl_constants())
    for path in SHADERS.rglob("*"):
        if path.is_file():
            text = path.read_text(encoding="utf-8")
            assert not re.search(r"binding\s*=\s*\d", text), f"{path.name}: a binding number written by hand"
