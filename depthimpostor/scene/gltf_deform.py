"""A glTF part as it moves (glTF 2.0, 3.7.2.2 morph targets, 3.7.3 skins, 3.11 animations): the
part's transform at a time, or, where it deforms, its mesh at a time, on the CPU (numpy).

A part that only moves rigidly (its node, or a parent, animated) keeps its mesh, in the file's
world space as written, and moves by `matrix(t) = world(t) @ world(rest)^-1`: what the renderer
does with any moving object (its transform changes; its GPU buffers, bounding sphere and the
ray-traced methods' bottom-level hierarchy stay). A part that deforms (a skin, morph targets)
has a new mesh at each time, `mesh_at(t)`, in the file's world space:

- morph targets add `sum_k w_k * target_k` to POSITION and NORMAL (renormalized), the weights the
  animation's at that time, else the node's `weights`, else the mesh's, else zeros;
- a skin places each vertex by `sum_i w_i * world(joint_i, t) @ inverseBindMatrix_i` (JOINTS_n,
  WEIGHTS_n: every set the primitive has), the node's own transform ignored as the specification
  says; normals by the cofactor matrix of that sum (its inverse transpose, up to a scale that the
  renormalization removes), which stays defined where the sum is singular;
- a part without a skin is then placed by its node's world matrix at that time.

The eye, the bakes and the truth all read a world's geometry (world.py), so they see one mesh per
time. Time 0 is the clip at time 0 (gltf_animation.py): the part's mesh as loaded is mesh_at(0).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from depthimpostor.errors import SceneError
from depthimpostor.meshes import Mesh
from depthimpostor.scene.fields import At, show
from depthimpostor.scene.gltf_animation import FileAnimation, node_weights
from depthimpostor.scene.gltf_data import GltfData
from depthimpostor.scene.gltf_file import Primitive, index, items, local_mesh, table


@dataclass(frozen=True, eq=False)
class Skin:
    index: int
    joints: tuple[int, ...]  # node indices
    inverse_binds: np.ndarray  # (joints, 4, 4)


@dataclass(frozen=True, eq=False)
class DeformingPrimitive:
    """One primitive's arrays (Primitive: as decoded, vertices in the accessors' order) and what
    deforms them: morph target deltas (targets, N, 3) and a skin's joints and weights (N, 4 a set)."""

    primitive: Primitive
    position_deltas: np.ndarray | None = None
    normal_deltas: np.ndarray | None = None
    joints: np.ndarray | None = None
    weights: np.ndarray | None = None

    def morphed(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Positions and normals with the morph targets added at `weights`."""
        p = self.primitive
        positions, normals = p.positions, p.normals
        if self.position_deltas is not None and weights.any():
            positions = positions + np.einsum("k,knc->nc", weights, self.position_deltas)
            if normals is not None and self.normal_deltas is not None:
                normals = normals + np.einsum("k,knc->nc", weights, self.normal_deltas)
        return positions, normals


def skinned(joints: np.ndarray, weights: np.ndarray, positions: np.ndarray, normals: np.ndarray | None,
            joint_matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Positions and normals placed by a skin: each vertex by the sum of its (N, k) `joints`'
    (joints, 4, 4) matrices times its `weights`."""
    skin = np.einsum("nj,njab->nab", weights, joint_matrices[joints])  # (N, 4, 4)
    placed = np.einsum("nab,nb->na", skin[:, :3, :3], positions) + skin[:, :3, 3]
    if normals is None:
        return placed, None
    linear = skin[:, :3, :3]
    # The cofactor matrix: det(L) inv(L)^T, the columns' cross products.
    cofactor = np.stack([np.cross(linear[:, :, 1], linear[:, :, 2]), np.cross(linear[:, :, 2], linear[:, :, 0]),
                         np.cross(linear[:, :, 0], linear[:, :, 1])], axis=2)
    sign = np.where(np.linalg.det(linear) < 0.0, -1.0, 1.0)[:, None]
    return placed, sign * np.einsum("nab,nb->na", cofactor, normals)


@dataclass(frozen=True, eq=False)
class PartMotion:
    """How one part (a node's primitives of one material) moves: rigidly with its node, or
    deformed (`primitives` with morph targets or a skin)."""

    animation: FileAnimation | None
    node: int
    rest_worlds: Mapping[int, np.ndarray]  # every scene node's world matrix as written
    primitives: tuple[DeformingPrimitive, ...]  # the part's, in its mesh's order
    skin: Skin | None
    default_weights: np.ndarray | None  # the node's or mesh's morph weights; None: no targets
    # The UV set its material's normal map reads (None: no normal map): a deformed mesh's tangents
    # are generated from it at each time (scene/tangents.py; a file's TANGENT is not skinned or morphed).
    tangent_set: int | None = None

    @property
    def deforms(self) -> bool:
        return self.skin is not None or self.default_weights is not None

    def matrix(self, time: float) -> np.ndarray:
        """The part's motion at `time` on top of its mesh: world(t) @ world(rest)^-1 (the
        identity for a part that deforms: its mesh_at(time) is placed already)."""
        if self.deforms or self.animation is None:
            return np.eye(4)
        return self.animation.worlds(time)[self.node] @ np.linalg.inv(self.rest_worlds[self.node])

    def weights_at(self, time: float) -> np.ndarray:
        animated = self.animation.weights(self.node, time) if self.animation is not None else None
        return animated if animated is not None else (self.default_weights if self.default_weights is not None
                                                      else np.zeros(0))

    def joint_matrices(self, time: float) -> np.ndarray | None:
        """(joints, 4, 4): each joint's world matrix at `time` times its inverse bind matrix, what a
        skin places its vertices by (None without a skin). The GPU path (gpu/deform.py) uploads these."""
        if self.skin is None:
            return None
        worlds = self.animation.worlds(time) if self.animation is not None else self.rest_worlds
        return np.stack([worlds[j] for j in self.skin.joints]) @ self.skin.inverse_binds

    def placement(self, time: float) -> np.ndarray:
        """The node's world matrix at `time`: where a part without a skin is placed after its morph."""
        worlds = self.animation.worlds(time) if self.animation is not None else self.rest_worlds
        return worlds[self.node]

    @property
    def gpu_refusal(self) -> str | None:
        """Why the renderer deforms this part on the CPU (None: deform.comp can, into the mesh
        buffer in place: what it cannot make is a per-triangle or per-mesh result)."""
        if self.tangent_set is not None:
            return "its normal map's tangents are generated again at each time (MikkTSpace, on the CPU)"
        if any(item.primitive.normals is None for item in self.primitives):
            return "a primitive without normals is given flat ones, one per triangle"
        return None

    def mesh_at(self, time: float) -> Mesh:
        """The part's mesh at `time`, in the file's world space."""
        weights = self.weights_at(time)
        joint_matrices = self.joint_matrices(time)
        deformed = []
        for item in self.primitives:
            positions, normals = item.morphed(weights) if weights.size else (item.primitive.positions,
                                                                              item.primitive.normals)
            if joint_matrices is not None and item.joints is not None and item.weights is not None:
                positions, normals = skinned(item.joints, item.weights, positions, normals, joint_matrices)
            deformed.append(dataclasses.replace(item.primitive, positions=positions, normals=normals, tangents=None))
        mesh = local_mesh(deformed, self.tangent_set)
        if self.skin is not None:
            return mesh
        return mesh.transformed(self.placement(time))


def read_skin(data: GltfData, k: int, worlds: Mapping[int, np.ndarray]) -> Skin:
    """skins[k]: its joints (nodes of the scene) and inverse bind matrices (identities where absent)."""
    header, source = data.header, data.source
    at = At(source, f"skins[{k}]")
    skin = items(header, "skins", source)[k]
    joints = skin.get("joints")
    if not isinstance(joints, list) or not joints:
        raise at.key("joints").error(f"expected an array of at least one node index, got {show(joints)}")
    nodes = [index(j, len(items(header, "nodes", source)), at.key("joints").index(i)) for i, j in enumerate(joints)]
    outside = [j for j in nodes if j not in worlds]
    if outside:
        raise at.key("joints").error(f"expected joints among the scene's nodes, got nodes[{outside[0]}], which the "
                                     f"scene does not hold")
    if "inverseBindMatrices" in skin:
        binds = data.accessor(index(skin["inverseBindMatrices"], len(header.get("accessors", [])),
                                    at.key("inverseBindMatrices")))
        if binds.shape != (len(nodes), 16) or binds.dtype.kind != "f" or not np.isfinite(binds).all():
            raise at.key("inverseBindMatrices").error(f"expected {len(nodes)} finite MAT4 (one per joint), got "
                                                      f"{binds.shape[0]} of {binds.shape[1]} components")
        inverse_binds = binds.reshape(-1, 4, 4).transpose(0, 2, 1)  # column-major
    else:
        inverse_binds = np.tile(np.eye(4), (len(nodes), 1, 1))
    return Skin(k, tuple(nodes), inverse_binds)


def _vertex_array(data: GltfData, attributes: Mapping[str, Any], name: str, count: int, at: At) -> np.ndarray:
    array = data.accessor(index(attributes[name], len(data.header.get("accessors", [])), at.key(name)))
    if len(array) != count:
        raise at.key(name).error(f"expected {count} elements (as many as POSITION), got {len(array)}")
    return array


def deforming_primitive(data: GltfData, primitive: Mapping[str, Any], decoded: Primitive, skin: Skin | None,
                        at: At) -> DeformingPrimitive:
    """The morph targets and skin attributes of meshes[m].primitives[p] (`at`)."""
    count = len(decoded.positions)
    position_deltas = normal_deltas = None
    targets = primitive.get("targets", [])
    if not isinstance(targets, list):
        raise at.key("targets").error(f"expected an array of morph targets, got {show(targets)}")
    if targets:
        tables = [table(t, at.key("targets").index(i)) for i, t in enumerate(targets)]
        position_deltas = np.stack([_vertex_array(data, t, "POSITION", count, at.key("targets").index(i))
                                    if "POSITION" in t else np.zeros((count, 3)) for i, t in enumerate(tables)])
        if decoded.normals is not None and any("NORMAL" in t for t in tables):
            normal_deltas = np.stack([_vertex_array(data, t, "NORMAL", count, at.key("targets").index(i))
                                      if "NORMAL" in t else np.zeros((count, 3)) for i, t in enumerate(tables)])
        if position_deltas.shape[2] != 3 or (normal_deltas is not None and normal_deltas.shape[2] != 3):
            raise at.key("targets").error("expected VEC3 POSITION and NORMAL deltas, got another type")
    joints = weights = None
    if skin is not None:
        attributes = table(primitive.get("attributes", {}), at.key("attributes"))
        sets = [n for n in range(8) if f"JOINTS_{n}" in attributes and f"WEIGHTS_{n}" in attributes]
        if not sets:
            raise at.key("attributes").error("expected JOINTS_0 and WEIGHTS_0 on a primitive of a skinned node, got "
                                             "neither (or one without the other)")
        joints = np.concatenate([_vertex_array(data, attributes, f"JOINTS_{n}", count, at.key("attributes"))
                                 for n in sets], axis=1)
        weights = np.concatenate([_vertex_array(data, attributes, f"WEIGHTS_{n}", count, at.key("attributes"))
                                  for n in sets], axis=1).astype(np.float64)
        if joints.dtype.kind not in "iu" or joints.min(initial=0) < 0 or joints.max(initial=0) >= len(skin.joints):
            raise at.key("attributes").key("JOINTS_0").error(
                f"expected unsigned integer joint indices below the skin's {len(skin.joints)} joints, got "
                f"{joints.max(initial=0) if joints.dtype.kind in 'iu' else 'floats'}")
        # Weights should sum to 1 (glTF 3.7.3.3); exporters round them: normalized, as three.js does.
        total = weights.sum(axis=1, keepdims=True)
        weights = np.where(total > 0.0, weights / np.where(total > 0.0, total, 1.0), 0.0)
    return DeformingPrimitive(decoded, position_deltas, normal_deltas, joints, weights)


def part_motion(data: GltfData, animation: FileAnimation | None, rest_worlds: Mapping[int, np.ndarray], node: int,
                mesh: int, group: list[tuple[int, Primitive]], tangent_set: int | None = None) -> PartMotion | None:
    """How the part of nodes[node] made of `group` ((primitive index, decoded)) moves; None where it
    stays as written (no skin, no morph targets, its node not moved by the animation). `tangent_set`:
    the UV set of its material's normal map (None: none), for its tangents."""
    header, source = data.header, data.source
    nodes, meshes = items(header, "nodes", source), items(header, "meshes", source)
    primitives = meshes[mesh].get("primitives", [])
    has_targets = any(table(primitives[p], At(source, f"meshes[{mesh}].primitives[{p}]")).get("targets")
                      for p, _ in group)
    skin = None
    if "skin" in nodes[node]:
        k = index(nodes[node]["skin"], len(items(header, "skins", source)), At(source, f"nodes[{node}].skin"))
        skin = read_skin(data, k, rest_worlds)
    moved = animation is not None and node in animation.moved_nodes
    if skin is None and not has_targets and not moved:
        return None
    default_weights = None
    if has_targets:
        counts = {len(primitives[p].get("targets", [])) for p, _ in group}
        if len(counts) != 1:
            raise SceneError(source, f"meshes[{mesh}].primitives",
                             f"expected every primitive of a mesh to have as many morph targets, got {sorted(counts)}")
        targets = counts.pop()
        default_weights = node_weights(header, node, mesh, targets, source)
        _check_weight_channels(animation, node, targets, source)
    deforming = tuple(deforming_primitive(data, primitives[p], decoded, skin,
                                          At(source, f"meshes[{mesh}].primitives[{p}]")) for p, decoded in group)
    return PartMotion(animation, node, rest_worlds, deforming, skin, default_weights, tangent_set)


def _check_weight_channels(animation: FileAnimation | None, node: int, targets: int, source: str) -> None:
    for channel in animation.channels if animation is not None else ():
        width = channel.sampler.values.shape[-1]
        if channel.node == node and channel.path == "weights" and width != targets:
            raise SceneError(source, f"animations[0].channels[{channel.index}].sampler",
                             f"expected {targets} weights a keyframe (the morph targets of nodes[{node}]'s mesh), got {width}")
