"""Diffuse (and checker) objects, rasterized with smooth normals.

The same shader draws them into the camera view and into depth images (the variant with
WRITE_DEPTH_IMAGE also stores the window depth in a 32-bit float attachment), so that a reflected
object is shaded exactly as the object itself. In the camera view, the objects that do not move
are drawn in one call (gpu/batches.py: the INSTANCED variant reads each object's transform and
material from instance attributes); those that move, and every object of a context without
multi-draw indirect, one call each with uniforms.
"""

from __future__ import annotations

import dataclasses
import functools
import weakref
from collections.abc import Iterable

import moderngl
import numpy as np

from ..geometry import ObjectGeometry
from ..lod import EyeView
from ..scene.model import CheckerMaterial, Scene, SceneObject, single_sided
from ..gpu.batches import ObjectBatch, face_class
from ..gpu.gl_state import RasterState, current_state, raster_state
from ..methods.atlas import BACK_FACES, BAKE_CULLS_FRONT_FACES, FRONT_FACES
from ..gpu.shaders import ProgramCache
from ..gpu.meshes import GpuMeshes
from ..gpu.scene_blocks import DrawnMaterials
from ..gpu.uniforms import blend_defines, matrix_bytes, packed, shading_defines, write, write_matrix
from ..node import Frame, GraphFacts, Node, Pass


DIFFUSE_PROGRAM = ("mesh.vert", "diffuse.frag")
#: The outward faces kept under a mirroring model matrix, which winds them the way GL calls front:
#: the state that keeps the back faces of an object that does not mirror.
MIRRORED_FRONT_FACES = BACK_FACES


def has_checker(objects: Iterable[SceneObject]) -> bool:
    """Does one of `objects` have a checker material?"""
    return any(isinstance(item.material, CheckerMaterial) for item in objects)


def diffuse_defines(scene: Scene, write_depth_image: bool, write_triangle_ids: bool = False,
                    back_layer: bool = False, instanced: bool = False, write_surface: bool = False,
                    checker: bool | None = None, transparent: bool = False) -> dict[str, int]:
    """The variant drawing into the frame, or (`write_depth_image`) into baked images: their
    visible surface, or (`back_layer`) the colour and depth of the nearest back face; and
    (`write_triangle_ids`: the hybrid method's) the triangle seen at each sample too; `instanced`:
    objects drawn in a batch, their transforms and material indices from instance attributes, the
    materials from the table (else one object a call, its record bound alone: DRAWN_MATERIAL);
    (`write_surface`: the planar and SSR methods') the world position and object seen; without
    the checker's code (NO_CHECKER) where no object drawn has one (`checker`; by default, none
    of the scene's); `transparent`: the eye's transparent pass (ALPHA_BLEND: the fragment's alpha
    out, passes/transparent.py). The hybrid's images (`write_triangle_ids`) hold blended surfaces
    whole (BLEND_WHOLE): its rays composite them exactly once they meet them there."""
    drawn_checker = has_checker(scene.objects) if checker is None else checker
    shading = shading_defines(scene, drawn_material=not instanced)
    # Whether GL calls an outward face front, under the passes' counter-clockwise front_face: it
    # does not (methods/atlas.py's BAKE_CULLS_FRONT_FACES), diffuse.frag's test of a back face.
    facing = {"OUTWARD_IS_GL_FRONT": int(BAKE_CULLS_FRONT_FACES == "front")} if "DOUBLE_SIDED" in shading else {}
    return {"WRITE_DEPTH_IMAGE": int(write_depth_image), **({"WRITE_TRIANGLE_ID": 1} if write_triangle_ids else {}),
            **({"BACK_LAYER": 1} if back_layer else {}), **({"INSTANCED": 1} if instanced else {}),
            **({"WRITE_SURFACE": 1} if write_surface else {}), **({} if drawn_checker else {"NO_CHECKER": 1}),
            **shading, **facing,
            **(blend_defines(scene, True) if transparent else blend_defines(scene, False) if write_triangle_ids else {})}


def viewer_of(view_projection: np.ndarray) -> np.ndarray:
    """diffuse.frag's u_eye: where the camera of `view_projection` is, (x, y, z, 1), or for an
    orthographic one the unit direction toward it, (x, y, z, 0). Clip space's (0, 0, -1, 0) is the
    point at infinity toward the near plane: back in the world it is the camera's centre (a
    perspective: homogeneous, w != 0), or the direction toward the camera (orthographic: w = 0)."""
    eye = np.linalg.inv(np.asarray(view_projection, np.float64)) @ np.array([0.0, 0.0, -1.0, 0.0])
    if abs(eye[3]) > 1e-12 * float(np.linalg.norm(eye[:3])):
        return np.array([*(eye[:3] / eye[3]), 1.0])
    return np.array([*(eye[:3] / np.linalg.norm(eye[:3])), 0.0])


class DiffusePass:
    def __init__(
        self, programs: ProgramCache, scene: Scene, meshes: GpuMeshes, materials: DrawnMaterials, *,
        write_depth_image: bool,
        triangle_offsets: dict[int, int] | None = None, back_layer: bool = False, batched: bool = False,
        write_surface: bool = False, checker: bool | None = None, transparent: bool = False,
    ) -> None:
        """`triangle_offsets` (by object index: where the object's triangles start in the list the
        ray-traced method's BVH is built from) makes the variant that writes each sample's triangle;
        `back_layer` the one drawing a depth image's back layer, `write_surface` the one writing the
        world position and object seen, `checker` whether an object it draws has a checker
        material, `transparent` the eye's transparent pass's (see diffuse_defines); `batched` draws the objects that do not move in one call
        (the context must have batches_supported); `materials`: the scene's records, of which a draw
        of one object binds its own (gpu/scene_blocks.py)."""
        self.programs = programs
        self.defines = diffuse_defines(scene, write_depth_image, triangle_offsets is not None, back_layer,
                                       write_surface=write_surface, checker=checker, transparent=transparent)
        batch_defines = diffuse_defines(scene, write_depth_image, triangle_offsets is not None, back_layer, instanced=True,
                                        write_surface=write_surface, checker=checker, transparent=transparent)
        self.instanced = programs.get(*DIFFUSE_PROGRAM, batch_defines) if batched else None
        self.materials = materials
        self.scene = scene  # for its texture slots
        self.meshes = meshes
        self.triangle_offsets = triangle_offsets
        self.culls_single_sided = not back_layer
        self._mirrored_view = False  # the current draw's (draw's mirrored_view)
        self._batch: ObjectBatch | None = None
        # Each object's uniforms, packed for the program they were packed for (_object_uniforms);
        # an object that moves is another ObjectGeometry at each time, and its old one's entry goes with it.
        self._packed: weakref.WeakKeyDictionary[ObjectGeometry, tuple[moderngl.Program, int, list[tuple[moderngl.Uniform, bytes]]]] = \
            weakref.WeakKeyDictionary()

    @property
    def batched(self) -> bool:
        return self.instanced is not None

    @functools.cached_property
    def program(self) -> moderngl.Program:
        """The variant drawing one object at a time (compiled when first needed: a batched pass
        needs it only for objects that move; then kept, since a bake asks for it at every image's
        draw, and the cache's key of a pass's defines took 0.2 ms an ask)."""
        return self.programs.get(*DIFFUSE_PROGRAM, self.defines)

    def draw(self, items: list[ObjectGeometry], view_projection: np.ndarray, mirrored_view: bool = False) -> int:
        """Draw the objects; returns the number of draw calls. `mirrored_view`: `view_projection`
        reflects the scene (a planar reflection's), which winds every face the other way on the
        screen."""
        calls = 0
        self._mirrored_view = mirrored_view
        # Metallic-roughness shading depends on the viewer: the frame's camera, or a baked image's.
        viewer = viewer_of(view_projection) if "METALLIC_ROUGHNESS" in self.defines else None
        if self.instanced is not None:
            still = [item for item in items if not item.object.moves]
            if still:
                write_matrix(self.instanced, "u_view_projection", view_projection)
                if viewer is not None:
                    write(self.instanced, "u_eye", viewer)
                self._write_view_mirrored(self.instanced)
                batch = self._batch_of(still)
                calls += batch.draw(self.instanced, 0, batch.first_closed)
                # Closed solids seen from outside: their back faces hidden, so culled (half the
                # triangles); single-sided materials' back faces are not there (face_class).
                with raster_state(self.programs.ctx, self._keeping(1)):
                    calls += batch.draw(self.instanced, batch.first_closed, batch.first_mirrored - batch.first_closed)
                if batch.first_mirrored < batch.draw_count:
                    with raster_state(self.programs.ctx, self._keeping(2)):
                        calls += batch.draw(self.instanced, batch.first_mirrored)
            items = [item for item in items if item.object.moves]
        if items:
            program = self.program
            write_matrix(program, "u_view_projection", view_projection)
            if viewer is not None:
                write(program, "u_eye", viewer)
            self._write_view_mirrored(program)
            for item in items:
                material, uniforms = self._object_uniforms(program, item)
                self.materials.bind(material)
                for uniform, data in uniforms:
                    uniform.write(data)
                self._render(program, item)
        return calls + len(items)

    def _render(self, program: moderngl.Program, item: ObjectGeometry) -> None:
        """Draw one object: a single-sided material's back faces culled (glTF's doubleSided false:
        they are not there) in a pass that draws what is seen and culls nothing itself; the back
        layer keeps them (it holds where a solid ends)."""
        ctx = self.programs.ctx
        enclosing = current_state(ctx)
        kept = face_class(item)
        if not self.culls_single_sided or enclosing.cull is not None or not single_sided(item.object.material):
            self.meshes.render(program, item)
            return
        with raster_state(ctx, dataclasses.replace(enclosing, cull=self._keeping(kept).cull)):
            self.meshes.render(program, item)

    def _keeping(self, kept: int) -> RasterState:
        """The state that keeps the outward faces of objects of face_class `kept` (1 or 2) in this
        draw's view (a mirrored view winds them the other way)."""
        return FRONT_FACES if (kept == 1) != self._mirrored_view else MIRRORED_FRONT_FACES

    def _write_view_mirrored(self, program: moderngl.Program) -> None:
        """diffuse.frag's u_view_mirrored (DOUBLE_SIDED programs: its test of a back face)."""
        write(program, "u_view_mirrored", int(self._mirrored_view))  # (where the program has it: write looks it up)

    def _object_uniforms(self, program: moderngl.Program,
                         item: ObjectGeometry) -> tuple[int, list[tuple[moderngl.Uniform, bytes]]]:
        """`item`'s material index (the record bound for its draw) and the uniforms `program` draws
        it with (object id, triangle offset, transforms) with their bytes, packed once per object: a
        bake draws each object into one image per mirror (a cube map, into six faces), and packing
        them anew each time took most of a thousand-object bake's Python time."""
        kept = self._packed.get(item)
        if kept is not None and kept[0] is program:
            return kept[1], kept[2]
        material = self.scene.material_index(item.object.material)
        # u_material_index: absent from a DRAWN_MATERIAL program (present in one reading the table).
        values: list[tuple[str, float | bytes]] = [("u_material_index", material), ("u_object_id", item.index)]
        if self.triangle_offsets is not None:
            values.append(("u_triangle_offset", self.triangle_offsets[item.index]))
        values += [("u_model", matrix_bytes(item.model_matrix)), ("u_normal_matrix", matrix_bytes(item.normal_matrix))]
        uniforms = [found for name, value in values if (found := packed(program, name, value)) is not None]
        self._packed[item] = (program, material, uniforms)
        return material, uniforms

    def _batch_of(self, items: list[ObjectGeometry]) -> ObjectBatch:
        """The batch of exactly these objects (made again when the list is another: objects that
        do not move keep their geometry, so a frame's list is the last one's)."""
        batch = self._batch
        if batch is None or len(batch.items) != len(items) or any(a is not b for a, b in zip(batch.items, items, strict=True)):
            if batch is not None:
                batch.release()
            batch = self._batch = ObjectBatch(self.programs.ctx, self.meshes, items, self.scene, self.triangle_offsets)
        return batch

    def release(self) -> None:
        if self._batch is not None:
            self._batch.release()
            self._batch = None


class DiffuseNode(Node):
    """The graph's diffuse node: the frame's diffuse objects (or, in the sample view, the baked
    images' samples standing for them), with the eye's surface beside the colour where SSR reads it."""

    stage = Pass.DIFFUSE
    when = "every frame"

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour", "frame depth", *facts.made("shadow maps", "environment lighting"))

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return ("frame colour", "frame depth", *facts.surface)

    def run(self, frame: Frame) -> bool:
        graph, targets = self.graph, frame.targets
        if graph.diffuse is None:
            return False
        # The objects at their levels for this frame's camera; the blended ones: passes/transparent.py.
        sampled, drawn = graph.sampled, graph.world.eye_drawn_for(EyeView.of_camera(frame.unjittered))
        if graph.show_samples and graph.samples is not None and sampled is not None:
            drawn = graph.world.analytic_planes  # the samples stand for the others
            graph.stats.draw_calls += graph.samples.draw(sampled, frame.camera)
        seen_from_eye = graph.seen_from_eye
        if seen_from_eye is not None:  # SSR's: the eye's surface beside the colour
            seen_from_eye.diffuse_framebuffer(targets.color_framebuffer, targets.size).use()
        graph.stats.draw_calls += graph.diffuse.draw(drawn, frame.camera.view_projection)
        targets.color_framebuffer.use()
        return True
