"""The render graph's stand-in node: the method's stand-in for the reflected objects baked (its
stale images, or its triangles uploaded), after the eye's sky and diffuse objects (whose depth
tells which images a frame's rays enter) and before the passes that read it; marked stale as the
world moves.
The methods made in the frame from the eye have the eye-images node instead (seen_from_eye.py)."""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING

import numpy as np

from ..culling import may_shadow
from ..node import Frame, GraphFacts, Node, Pass

if TYPE_CHECKING:
    from ..world import World


class StandInNode(Node):
    stage = Pass.STAND_IN
    when = "once; an image again when its reflector, its object or a light shading it moves"
    bakes = True

    @staticmethod
    def reads(facts: GraphFacts) -> tuple[str, ...]:
        # Baked images are shaded, shadows included: the maps first. A BVH is triangles alone.
        return facts.made("shadow maps", "environment lighting") if "baked images" in facts.stand_in else ()

    @staticmethod
    def writes(facts: GraphFacts) -> tuple[str, ...]:
        return () if facts.made_in_frame else facts.stand_in

    def stale(self) -> bool:
        return self.graph.stand_in is not None and self.graph.stand_in_stale()

    def run(self, frame: Frame) -> bool:
        """The method's stale images but those of reflectors in reflectors (the bounce node's),
        or its triangles uploaded."""
        graph = self.graph
        if graph.stand_in is None:
            return False
        baked = graph.baked_images
        before_counts = baked.bake_counts.copy() if baked is not None else Counter()
        graph.stats.draw_calls += graph.stand_in.bake()
        if baked is not None:
            graph.count_images(baked.bake_counts - before_counts)
        graph.stand_in_baked = True
        return True

    def follow(self, earlier: World, world: World) -> None:
        """Stale: an image whose reflector or object moved, every image when a light moved, and an
        image of an object on which a moved caster's shadow may fall (before or after its move);
        the triangle methods' instances where their objects moved."""
        graph = self.graph
        moved, moved_lights = world.moved(earlier), world.moved_lights(earlier)
        if graph.stand_in is None or not (moved or moved_lights):
            return
        baked = graph.baked_images
        if baked is None:  # the triangle methods' BVH: its instances moved, its meshes' hierarchies kept
            triangles = graph.triangles
            if triangles is not None and any(g.index in moved for g in world.reflected_objects):
                triangles.move({g.index: g for g in world.geometry})
            return
        moved_casters = [g for g in world.shadow_casters if g.index in moved]
        shadowed = set(world.lit_scene.shadowed_lights)
        lights, before = world.lit_scene.lights, {g.index: g for g in earlier.geometry}
        relit = {g.index for g in world.reflected_objects} if moved_lights else set()
        shadows = {
            receiver.index for receiver in world.reflected_objects for light in shadowed
            for caster in moved_casters if receiver is not caster
            for sphere in (before[caster.index].bounding_sphere, caster.bounding_sphere)
            if may_shadow(np.asarray(lights[light].position, float), lights[light].radius, sphere,
                          receiver.bounding_sphere)
        }
        baked.move({g.index: g for g in world.geometry}, moved, relit | shadows)
