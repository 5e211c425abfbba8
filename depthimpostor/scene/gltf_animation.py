"""A glTF file's animation (glTF 2.0, 3.11, and Appendix C for the interpolations), sampled at a
scene time: every node's world matrix, and morph target weights, at that time.

What plays: the file's **first** animation (`animations[0]`), alone. glTF leaves the choice to the
application; a file's animations are usually alternatives (a walk, a run, an idle clip of one
character), which played at once would override one another node by node. The others are listed
as ignored (gltf_file.ignored_features). The clip **loops**: scene time t plays clip time
t mod D, D the largest keyframe time of its samplers (three.js and the Sample Viewer loop over
the clip's duration alike); a sampler clamps to its first and last keyframes outside its own
range. A node no channel targets keeps its rest transform (its `matrix`, or its TRS); a channel
replaces one of translation, rotation and scale of its node, or the weights of its node's mesh.

The three interpolations as Appendix C gives them: STEP holds a keyframe's value until the next;
LINEAR blends linearly, but rotations by slerp along the shorter arc; CUBICSPLINE is the cubic
Hermite spline of each keyframe's (in-tangent, value, out-tangent) triple, its tangents scaled by
the keyframe interval, a rotation normalized after.

Every problem is a SceneError at the JSON path: `x.glb: animations[0].channels[2].sampler: ...`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from depthimpostor.errors import SceneError
from depthimpostor.scene.fields import At, numbers, show
from depthimpostor.scene.gltf_data import GltfData
from depthimpostor.scene.gltf_file import index, items, node_matrix, scene_nodes, table

INTERPOLATIONS = ("LINEAR", "STEP", "CUBICSPLINE")
#: The components of one keyframe's value for each target path (weights: one per morph target).
PATH_WIDTHS = {"translation": 3, "rotation": 4, "scale": 3}
#: A scale component nearer 0 than this is drawn at this (with its sign): a node animated to
#: nothing (a common way to pop a part in or out) would otherwise leave no normals to draw with.
SMALLEST_SCALE = 1e-6
#: Times worked out and kept per file (a frame asks for each part's node at one time; the eye, the
#: bakes and the truth of that frame share them).
_KEPT_TIMES = 4


@dataclass(frozen=True, eq=False)
class Sampler:
    """Keyframe `times` (K,), increasing, and `values` (K, width) (CUBICSPLINE: (K, 3, width),
    each keyframe's in-tangent, value and out-tangent)."""

    times: np.ndarray
    values: np.ndarray
    interpolation: str

    def at(self, t: float, rotation: bool = False) -> np.ndarray:
        """The value at clip time `t` (Appendix C); a rotation as a unit quaternion (x, y, z, w)."""
        times, cubic = self.times, self.interpolation == "CUBICSPLINE"
        values = self.values[:, 1] if cubic else self.values
        if t <= times[0] or len(times) == 1:
            value = values[0]
        elif t >= times[-1]:
            value = values[-1]
        else:
            k = int(np.searchsorted(times, t, side="right")) - 1  # times[k] <= t < times[k + 1]
            interval = float(times[k + 1] - times[k])
            s = (t - float(times[k])) / interval
            if self.interpolation == "STEP":
                value = values[k]
            elif cubic:
                out_tangent, in_tangent = self.values[k, 2], self.values[k + 1, 0]
                value = ((2 * s**3 - 3 * s**2 + 1) * values[k] + interval * (s**3 - 2 * s**2 + s) * out_tangent
                         + (-2 * s**3 + 3 * s**2) * values[k + 1] + interval * (s**3 - s**2) * in_tangent)
            elif rotation:
                value = slerp(values[k], values[k + 1], s)
            else:
                value = (1.0 - s) * values[k] + s * values[k + 1]
        if rotation:
            length = float(np.linalg.norm(value))
            return value / length if length > 0.0 else np.array([0.0, 0.0, 0.0, 1.0])
        return np.asarray(value, np.float64)


def slerp(a: np.ndarray, b: np.ndarray, s: float) -> np.ndarray:
    """Appendix C's spherical linear interpolation of unit quaternions, along the shorter arc."""
    dot = float(np.dot(a, b))
    sign = -1.0 if dot < 0.0 else 1.0
    angle = math.acos(min(abs(dot), 1.0))
    if angle < 1e-6:  # sin(angle) -> 0: the arc is a straight line to within rounding
        return (1.0 - s) * a + s * sign * b
    return (math.sin(angle * (1.0 - s)) * a + sign * math.sin(angle * s) * b) / math.sin(angle)


@dataclass(frozen=True, eq=False)
class Channel:
    index: int  # in the animation's `channels`
    node: int
    path: str  # "translation", "rotation", "scale" or "weights"
    sampler: Sampler


def trs_matrix(translation: np.ndarray, rotation: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """T @ R @ S (glTF 3.5.3), the quaternion (x, y, z, w) normalized, a scale of ~0 kept off 0."""
    x, y, z, w = rotation / max(float(np.linalg.norm(rotation)), 1e-300)
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    scale = np.where(np.abs(scale) < SMALLEST_SCALE, np.copysign(SMALLEST_SCALE, scale), scale)
    matrix = np.eye(4)
    matrix[:3, :3] = (np.eye(3) + 2.0 * w * cross + 2.0 * cross @ cross) @ np.diag(scale)
    matrix[:3, 3] = translation
    return matrix


@dataclass(eq=False)
class FileAnimation:
    """The file's first animation over its scene's node tree."""

    source: str
    name: str  # the animation's name, or "animations[0]"
    duration: float  # seconds: the clip loops after it
    channels: tuple[Channel, ...]
    tree: tuple[tuple[int, int | None], ...]  # (node, parent) of the scene's nodes, parents first
    rest: dict[int, np.ndarray]  # each node's local matrix as written
    rest_worlds: dict[int, np.ndarray]  # each node's world matrix as written (scene_nodes')
    rest_trs: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]  # each animated node's TRS as written
    _worlds: dict[float, dict[int, np.ndarray]] = field(default_factory=dict)

    def clip_time(self, time: float) -> float:
        """The clip's time at scene time `time`: it loops every `duration` seconds."""
        return float(time % self.duration) if self.duration > 0.0 else 0.0

    @functools.cached_property
    def moved_nodes(self) -> frozenset[int]:
        """The nodes whose world matrix the clip can change: those it animates and their descendants."""
        moved = {c.node for c in self.channels if c.path != "weights"}
        for node, parent in self.tree:
            if parent in moved:
                moved.add(node)
        return frozenset(moved)

    def worlds(self, time: float) -> dict[int, np.ndarray]:
        """Every scene node's world matrix at scene time `time`."""
        t = self.clip_time(time)
        if t not in self._worlds:
            local = dict(self.rest)
            trs = {node: [np.array(v) for v in values] for node, values in self.rest_trs.items()}
            for channel in self.channels:
                if channel.path != "weights":
                    slot = ("translation", "rotation", "scale").index(channel.path)
                    trs[channel.node][slot] = channel.sampler.at(t, rotation=channel.path == "rotation")
            for node, (translation, rotation, scale) in trs.items():
                local[node] = trs_matrix(translation, rotation, scale)
            # A node the clip does not move keeps its world matrix to the bit (its part stays put exactly).
            moved, worlds = self.moved_nodes, dict(self.rest_worlds)
            for node, parent in self.tree:
                if node in moved:
                    worlds[node] = local[node] if parent is None else worlds[parent] @ local[node]
            if len(self._worlds) >= _KEPT_TIMES:
                self._worlds.pop(next(iter(self._worlds)))
            self._worlds[t] = worlds
        return self._worlds[t]

    def weights(self, node: int, time: float) -> np.ndarray | None:
        """The morph weights a channel gives `node` at scene time `time`, or None (none animates them)."""
        for channel in self.channels:
            if channel.node == node and channel.path == "weights":
                return channel.sampler.at(self.clip_time(time))
        return None


def _sampler(data: GltfData, value: Any, path: str, width: int | None, at: At) -> Sampler:
    """animations[a].samplers[s], checked for a channel of `path` (`width` values a keyframe;
    None: a multiple of the keyframes, the morph weights)."""
    sampler = table(value, at)
    interpolation = sampler.get("interpolation", "LINEAR")
    if interpolation not in INTERPOLATIONS:
        raise at.key("interpolation").error(f"expected one of {', '.join(INTERPOLATIONS)}, got {show(interpolation)}")
    if "input" not in sampler or "output" not in sampler:
        raise at.error("expected `input` and `output` accessors, got " + ("neither" if "input" not in sampler and
                                                                          "output" not in sampler else "one of them"))
    count = len(data.header.get("accessors", []))
    times = data.accessor(index(sampler["input"], count, at.key("input")))
    if times.shape[1] != 1 or times.dtype.kind != "f" or not len(times):
        raise at.key("input").error(f"expected at least one float SCALAR keyframe time, got {times.shape[0]} "
                                    f"of {times.shape[1]} components")
    times = times[:, 0]
    if not (np.isfinite(times).all() and times[0] >= 0.0 and (np.diff(times) > 0.0).all()):
        raise at.key("input").error(f"expected keyframe times >= 0, finite and strictly increasing, got "
                                    f"{show(times[:8].tolist())}")
    values = data.accessor(index(sampler["output"], count, at.key("output")))
    per_key = 3 if interpolation == "CUBICSPLINE" else 1
    if values.dtype.kind != "f" or not np.isfinite(values).all():
        raise at.key("output").error("expected finite floats (or normalized integers), got "
                                     + ("integers" if values.dtype.kind != "f" else "NaN or infinity"))
    if width is None:  # weights: output scalars, one per morph target per keyframe (x3 for splines)
        if values.shape[1] != 1 or len(values) % (per_key * len(times)):
            raise at.key("output").error(f"expected SCALAR weights, a multiple of {per_key} x {len(times)} keyframes, "
                                         f"got {len(values)} of {values.shape[1]} components")
        width = len(values) // (per_key * len(times))
        values = values.reshape(-1, width)
    elif values.shape[1] != width or len(values) != per_key * len(times):
        raise at.key("output").error(f"expected {per_key * len(times)} values of {width} components for {path} "
                                     f"({len(times)} keyframes, {interpolation}), got {len(values)} of {values.shape[1]}")
    if per_key == 3:
        values = values.reshape(len(times), 3, width)
    return Sampler(times.astype(np.float64), values, interpolation)


def _channels(data: GltfData, animation: Mapping[str, Any], tree: dict[int, int | None], at: At) -> list[Channel]:
    nodes = items(data.header, "nodes", data.source)
    samplers = animation.get("samplers", [])
    if not isinstance(samplers, list):
        raise at.key("samplers").error(f"expected an array, got {show(samplers)}")
    channels = animation.get("channels", [])
    if not isinstance(channels, list):
        raise at.key("channels").error(f"expected an array, got {show(channels)}")
    read = []
    for c, value in enumerate(channels):
        channel_at = at.key("channels").index(c)
        channel = table(value, channel_at)
        target = table(channel.get("target"), channel_at.key("target"))
        if "node" not in target:  # glTF 3.11: without a node (KHR_animation_pointer's target), the channel is ignored
            continue
        path = target.get("path")
        if path not in (*PATH_WIDTHS, "weights"):
            raise channel_at.key("target").key("path").error(
                f'expected "translation", "rotation", "scale" or "weights", got {show(path)}')
        node = index(target["node"], len(nodes), channel_at.key("target").key("node"))
        if "matrix" in nodes[node] and path != "weights":
            raise channel_at.key("target").key("node").error(
                f"expected a node with TRS properties (glTF 3.11: an animated node has no `matrix`), got nodes[{node}] "
                f"with a matrix")
        s = index(channel.get("sampler"), len(samplers), channel_at.key("sampler"))
        try:
            sampler = _sampler(data, samplers[s], path, PATH_WIDTHS.get(path), at.key("samplers").index(s))
        except SceneError as error:  # said of the channel too: a sampler may serve several
            raise SceneError(error.source, error.path, f"{error.detail} (the sampler of channels[{c}], the {path} "
                                                       f"of nodes[{node}])") from None
        if node in tree:  # a node outside the scene is not drawn: its channel moves nothing seen
            read.append(Channel(c, node, path, sampler))
    return read


def _rest_trs(node: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (np.array(node.get("translation", [0, 0, 0]), np.float64),
            np.array(node.get("rotation", [0, 0, 0, 1]), np.float64), np.array(node.get("scale", [1, 1, 1]), np.float64))


def read_animation(data: GltfData) -> FileAnimation | None:
    """The file's first animation, or None where it has none (or none that moves a scene node)."""
    header, source = data.header, data.source
    animations = items(header, "animations", source)
    if not animations:
        return None
    nodes = items(header, "nodes", source)
    tree: dict[int, int | None] = {}
    rest: dict[int, np.ndarray] = {}  # each node's local matrix
    rest_worlds: dict[int, np.ndarray] = {}
    for i, world in scene_nodes(header, source):  # checked there: a tree, finite, affine
        tree[i] = tree.get(i)
        children = nodes[i].get("children", [])
        tree.update(dict.fromkeys(children if isinstance(children, list) else [], i))  # (scene_nodes refuses others)
        rest[i], rest_worlds[i] = node_matrix(nodes[i], At(source, f"nodes[{i}]")), world
    animation = animations[0]
    channels = _channels(data, animation, tree, At(source, "animations[0]"))
    if not channels:
        return None
    name = animation.get("name")
    duration = max(float(c.sampler.times[-1]) for c in channels)
    animated = {c.node for c in channels if c.path != "weights"}
    return FileAnimation(source, name if isinstance(name, str) and name else "animations[0]", duration, tuple(channels),
                         tuple(tree.items()), rest, rest_worlds, {i: _rest_trs(nodes[i]) for i in animated})


def node_weights(header: Mapping[str, Any], node: int, mesh: int, targets: int, source: str) -> np.ndarray:
    """A node's morph weights as written: its `weights`, else its mesh's, else zeros (glTF 3.7.2.2)."""
    nodes, meshes = items(header, "nodes", source), items(header, "meshes", source)
    for value, at in ((nodes[node], At(source, f"nodes[{node}]")), (meshes[mesh], At(source, f"meshes[{mesh}]"))):
        if "weights" in value:
            return np.array(at.key("weights").read(value["weights"], numbers(targets)), np.float64)
    return np.zeros(targets)
