"""The reproductions of issue 34 (part two) for glTF files and images, each built here, small, in
memory (a million nodes are a JSON string, a 16384^2 PNG a stream of compressed zeros): hangs,
memory, tracebacks and misleading refusals. Each gives one line and exit 2 (`plan`), or loads;
where the fix is about cost, the test counts the work (passes over a mesh, walks of the node
tree, arrays decoded) rather than timing it."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import moderngl
import numpy as np
import pytest

from depthimpostor import image_files, textures
from depthimpostor.api import render_image
from depthimpostor.errors import GpuLimitError
from depthimpostor.gpu.limits import context_limits, use_limits
from depthimpostor.hdr import write_hdr
from depthimpostor.geometry import scene_geometry
from depthimpostor.scene import gltf_file, gltf_planes, load_scene
from depthimpostor.scene.gltf import read_gltf
from gltf_files import GltfWriter
from test_cli import assert_one_line_error, run_in_process

TRIANGLE = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]


def refused(path: Path, capsys: pytest.CaptureFixture[str], *fragments: str) -> str:
    code, stdout, stderr = run_in_process(["plan", str(path)], capsys)
    return assert_one_line_error(code, stdout, stderr, *fragments)


def box_writer() -> GltfWriter:
    w = GltfWriter()
    w.node(mesh=w.mesh(w.box(material=w.material("Grey", (0.5, 0.5, 0.5)))))
    return w


def png_stream(width: int, height: int, depth: int = 8, colour: int = 0) -> bytes:
    """A valid PNG of zeros (black), compressed a row at a time: a 16384^2 image in a few MB of
    memory and well under a second."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    row = bytes(1 + (width * depth * {0: 1, 2: 3}[colour] + 7) // 8)  # a filter byte, then the samples
    compressor = zlib.compressobj(9)
    data = b"".join(compressor.compress(row) for _ in range(height)) + compressor.flush()
    header = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", data) + chunk(b"IEND", b"")


def png_header(width: int, height: int) -> bytes:
    """A PNG's signature and header claiming width x height, and no pixels."""
    body = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"".join([b"\x89PNG\r\n\x1a\n", *(struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
                                            for kind, data in ((b"IHDR", body), (b"IDAT", b""), (b"IEND", b"")))])


def textured_scene(folder: Path, texture: str = "floor.png", environment: str = "") -> Path:
    sky = f'[environment]\ntype = "equirect"\npath = "{environment}"\n\n' if environment else ""
    path = folder / "s.toml"
    path.write_text(f'{sky}[[objects]]\nname = "floor"\nshape = {{ type = "plane", size = [2.0, 2.0] }}\n'
                    f'material = {{ type = "diffuse", texture = "{texture}" }}\n')
    return path


def gltf_with_image(folder: Path, image: dict[str, object]) -> Path:
    w = GltfWriter()
    material = w.material("Wood")
    w.json["images"] = [image]
    w.json["textures"] = [{"source": 0}]
    w.json["materials"][material]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    w.node(mesh=w.mesh(w.primitive(TRIANGLE, uvs=[[0, 0], [1, 0], [0, 1]], material=material)))
    return w.write(folder / "x.glb")


# --- item 1: a flat fan of triangles sharing a corner ---------------------------------------------------------


def counting_box_passes(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    box = gltf_planes._box

    def counted(*args: object) -> object:
        calls.append(1)
        assert len(calls) <= 10, "find_rectangle tries a box per edge (quadratic on a fan)"
        return box(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(gltf_planes, "_box", counted)
    return calls


def test_a_fan_of_30000_triangles_on_one_corner_costs_two_passes(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """It took over two minutes: every edge at the corner was tried, each a pass over the mesh."""
    calls = counting_box_passes(monkeypatch)
    w = GltfWriter()
    w.node(mesh=w.mesh(w.primitive(TRIANGLE, [[0, 1, 2]] * 30000)))
    model = read_gltf(w.write(tmp_path / "fan.glb"), "fan.glb")
    assert [part.rectangle for part in model.parts] == [None]  # the triangle, 30,000 times: no rectangle
    assert len(calls) <= 2


def test_a_rectangle_fanned_from_its_corner_is_still_found(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A 2 x 1 rectangle as 200 triangles fanned from its corner (0, 0): every edge there lies in
    its right angle, and the two sides are the ends of that angle."""
    calls = counting_box_passes(monkeypatch)
    far = [(2.0, 0.0)] + [(2.0, y) for y in np.linspace(0.01, 1.0, 100)] + [(x, 1.0) for x in np.linspace(1.98, 0.0, 100)]
    positions = [[0.0, 0.0, 0.0]] + [[x, 0.0, -y] for x, y in far]
    w = GltfWriter()
    w.node(mesh=w.mesh(w.primitive(positions, [[0, k, k + 1] for k in range(1, len(positions) - 1)])))
    (part,) = read_gltf(w.write(tmp_path / "fan.glb"), "fan.glb").parts
    assert part.rectangle is not None
    assert sorted(part.rectangle.size) == pytest.approx([1.0, 2.0])
    assert np.allclose(part.rectangle.centre, [1.0, 0.0, -0.5])
    assert len(calls) <= 2


# --- item 2: a million nodes, a chain of 10^5 -----------------------------------------------------------------


def write_chain(folder: Path, count: int, moved: bool = False) -> Path:
    """A box at the end of a chain of `count` nodes, each the only child of the one before (each
    with a translation where `moved`): the nodes written as JSON text directly (a million are 17 MB)."""
    path = box_writer().write(folder / "chain.gltf")
    document = json.loads(path.read_text()) | {"scenes": [{"nodes": [0]}], "nodes": "NODES"}
    node = b'{"children":[%d],"translation":[0,0,0]}' if moved else b'{"children":[%d]}'
    last = b',{"mesh":0,"translation":[0,0,0]}' if moved else b',{"mesh":0}'
    nodes = b",".join(node % (i + 1) for i in range(count - 1)) + last
    path.write_bytes(json.dumps(document).encode().replace(b'"NODES"', b"[" + nodes + b"]"))
    return path


def test_a_million_nodes_are_refused_before_the_json_is_parsed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """It ran over 90 s and took 1.3 GB, with no answer."""
    path = write_chain(tmp_path, 10**6)
    refused(path, capsys, f"{path}: expected glTF JSON of at most 262,144 objects", "got about 1,000,0")


def counting_node_matrices(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """A list that grows by one each time a node's matrix is read (gltf_file.node_matrix)."""
    calls: list[int] = []
    matrix = gltf_file.node_matrix

    def counted(*args: object) -> object:
        calls.append(1)
        return matrix(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(gltf_file, "node_matrix", counted)
    return calls


def test_a_chain_of_10000_nodes_is_walked_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A chain of 100,000 took 60 s: the tree was walked three times, each node's matrix parsed
    each time. (Each node gets a translation here, so that each has a matrix to read.) 10,000
    nodes show a second walk as well (20,000 reads), and are ten times deeper than Python's
    recursion limit: a walk by recursion fails here too."""
    calls = counting_node_matrices(monkeypatch)
    scene = load_scene(write_chain(tmp_path, 10**4, moved=True))
    assert len(scene.objects) == 1
    assert len(calls) == 10**4


# --- item 3: triangles and memory counted before decoding ---------------------------------------------------


def no_decoding(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object) -> None:
        raise AssertionError("decoded before the counts were checked")

    monkeypatch.setattr("depthimpostor.scene.gltf.decode_primitive", refuse)


def test_more_triangles_than_the_hybrid_names_are_refused_before_decoding(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """2^14 triangles placed by 1,025 nodes: 2^24 + 2^14 (it was refused after 73 s and 7.7 GB)."""
    no_decoding(monkeypatch)
    w = GltfWriter()
    mesh = w.mesh(w.primitive(TRIANGLE, [[0, 1, 2]] * 2**14))
    for k in range(1025):
        w.node(mesh=mesh, translation=[float(k), 0.0, 0.0])
    refused(w.write(tmp_path / "many.glb"), capsys, "meshes: expected at most 16,777,216 triangles placed by the "
            "scene's nodes", "got 16,793,600, counted from the accessors before decoding")


def test_an_accessor_of_a_hundred_million_zeros_is_refused_before_decoding(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """An accessor without a buffer view is zeros: its count is bounded by no file size."""
    no_decoding(monkeypatch)
    w = GltfWriter()
    primitive = w.primitive(TRIANGLE, [0, 1, 2])
    w.json["accessors"][primitive["attributes"]["POSITION"]] = {"componentType": 5126, "type": "VEC3", "count": 10**8}
    w.node(mesh=w.mesh(primitive))
    refused(w.write(tmp_path / "zeros.glb"), capsys, "accessors: expected geometry that decodes into at most 2 GiB, "
            "got 2.24 GiB")


# --- item 4, 13, 18: image sizes from their headers ---------------------------------------------------------


def test_a_10000_square_texture_is_refused_from_its_header(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """It took 67 s and 10 GB, then drew the frame."""
    (tmp_path / "floor.png").write_bytes(png_stream(10000, 10000))
    refused(textured_scene(tmp_path), capsys, "objects[0].material.texture: expected an image of at most 67,108,864 "
            "texels (8192x8192), got", "10000x10000, 100,000,000 texels (its header, read before decoding)")


def test_the_scenes_images_together_must_fit_in_memory(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Each image within its own limit, but more of them than the machine's memory holds (ten
    8192^2 textures: 2.5 GiB kept, more while each decodes): refused from the header of the one
    that would not fit, before it is decoded, naming it (the budget here 3 MiB: three 512^2
    images keep 1 MiB each and take 2 MiB while one decodes)."""
    monkeypatch.setattr(image_files, "available_memory", lambda: 3 * 2**20)
    for name in ("a.png", "b.png", "c.png"):
        (tmp_path / name).write_bytes(png_stream(512, 512))
    objects = "".join(f'[[objects]]\nname = "{name[0]}"\nshape = {{ type = "plane", size = [2.0, 2.0] }}\n'
                      f'material = {{ type = "diffuse", texture = "{name}" }}\nposition = [{k}.0, 0.0, 0.0]\n'
                      for k, name in enumerate(("a.png", "b.png", "c.png")))
    (tmp_path / "s.toml").write_text(objects)
    refused(tmp_path / "s.toml", capsys, "objects[2].material.texture: expected images that fit in the machine's "
            "available memory once decoded (3.0 MiB when the scene began loading; its images so far keep 2.0 MiB)",
            "c.png'", "512x512, which takes 2.0 MiB to decode (its header, read before decoding)")
    # A file met before in the scene is not decoded again, nor charged again: with the caches
    # emptied, a.png, b.png and a.png again fit where three files would not.
    monkeypatch.setattr(textures, "_CACHE", {})
    monkeypatch.setattr(textures, "_DECODED_FILES", {})
    (tmp_path / "s.toml").write_text(objects.replace('"c.png"', '"a.png"'))
    assert run_in_process(["plan", str(tmp_path / "s.toml")], capsys)[0] == 0


def test_the_environment_map_is_charged_to_the_scenes_image_budget(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """An 8192x4096 sky keeps 384 MiB in float RGB, more while it decodes: it was read whatever the
    memory its textures had left. 512x256 takes 3.5 MiB to decode and keeps 1.5: refused by its
    header where 3 MiB are available, read where 4 are, and then counted against the textures."""
    with open(tmp_path / "sky.hdr", "wb") as file:
        write_hdr(file, np.full((256, 512, 3), 0.5, np.float32), ".hdr")
    (tmp_path / "floor.png").write_bytes(png_stream(1024, 512))  # keeps 2 MiB, 4 MiB while it decodes
    (tmp_path / "small.png").write_bytes(png_stream(64, 64))
    monkeypatch.setattr(image_files, "available_memory", lambda: 3 * 2**20)
    refused(textured_scene(tmp_path, environment="sky.hdr"), capsys, "environment.path", '"sky.hdr": expected '
            "images that fit in the machine's available memory once decoded (3.0 MiB when the scene began loading; "
            "its images so far keep 0.0 MiB), got 512x256, which takes 3.5 MiB to decode (its header, read before "
            "decoding)")
    monkeypatch.setattr(image_files, "available_memory", lambda: 4 * 2**20)
    monkeypatch.setattr(textures, "_CACHE", {})
    monkeypatch.setattr(textures, "_DECODED_FILES", {})
    refused(textured_scene(tmp_path, environment="sky.hdr"), capsys, "objects[0].material.texture", "its images "
            "so far keep 1.5 MiB), got", "1024x512, which takes 4.0 MiB to decode")
    assert run_in_process(["plan", str(textured_scene(tmp_path))], capsys)[0] == 0  # the texture alone fits
    assert run_in_process(["plan", str(textured_scene(tmp_path, "small.png", "sky.hdr"))], capsys)[0] == 0


@pytest.mark.parametrize("size", [(65535, 65535), (16384, 16384)])
def test_a_png_past_pillows_guard_is_refused_by_its_size(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                         size: tuple[int, int]) -> None:
    """A header claiming 65535^2 (no data behind it), a real 16384^2 (1-bit): Pillow's
    DecompressionBombError was a traceback, and in a glTF file 'an image trimesh can decode'."""
    data = png_stream(*size, depth=1) if size[0] == 16384 else png_header(*size)
    (tmp_path / "floor.png").write_bytes(data)
    expected = f"{size[0]}x{size[1]}, {size[0] * size[1]:,} texels (its header, read before decoding)"
    refused(textured_scene(tmp_path), capsys, "objects[0].material.texture: expected an image of at most", expected)
    (tmp_path / "y.png").write_bytes(data)
    refused(gltf_with_image(tmp_path, {"uri": "y.png"}), capsys, "images[0]: expected an image of at most", expected)


def test_a_16k_sky_is_refused_from_its_header(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """16384 x 8192 was refused after 22 s and 3.1 GB; 100,000 x 200,000 was a cv2.error. The
    pixels behind these headers are missing: only the header is read."""
    (tmp_path / "floor.png").write_bytes(png_stream(4, 4))
    for width, height in ((16384, 8192), (200000, 100000)):
        (tmp_path / "sky.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width))
        refused(textured_scene(tmp_path, environment="sky.hdr"), capsys, "environment.path",
                f"expected an image of at most 16384 pixels a side and 33,554,432 in all (8192x4096), got "
                f"{width}x{height} (its header, read before decoding)")


def test_an_exr_whose_data_window_lies_is_one_line(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    """`ValueError: ... file has 0 parts` was a traceback, and OpenEXR printed lines of its own
    (one of them to stdout, where `-o /dev/stdout` writes the image)."""
    with open(tmp_path / "sky.exr", "wb") as file:
        write_hdr(file, np.full((4, 8, 3), 0.5, np.float32), ".exr")
    data = (tmp_path / "sky.exr").read_bytes()
    at = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    (tmp_path / "sky.exr").write_bytes(data[:at] + struct.pack("<4i", 0, 0, 7, 1000) + data[at + 16:])
    (tmp_path / "floor.png").write_bytes(png_stream(4, 4))
    code, stdout, stderr = run_in_process(["plan", str(textured_scene(tmp_path, environment="sky.exr"))], capfd)
    assert_one_line_error(code, stdout, stderr, 'environment.path: "sky.exr": expected a readable OpenEXR image, got '
                          "one OpenEXR cannot decode")


def test_a_texture_wider_than_the_gl_holds_is_refused(ctx: moderngl.Context, tmp_path: Path) -> None:
    """16,385 x 2 was drawn black: the width is checked as the height is (here against a GL of 32)."""
    (tmp_path / "floor.png").write_bytes(png_stream(33, 2, colour=2))
    limits = context_limits(ctx)
    use_limits(ctx, limits.__class__(**{**limits.__dict__, "max_texture_size": 32}))
    try:
        with pytest.raises(GpuLimitError, match=r"floor\.png\) is 33x2, over this GL's GL_MAX_TEXTURE_SIZE of 32"):
            render_image(textured_scene(tmp_path), size=(8, 8), ctx=ctx)
    finally:
        use_limits(ctx, limits)


# --- item 11: one rule for paths leaving the folder ---------------------------------------------------------


@pytest.mark.parametrize("field, line", [
    ("texture", 'material = { type = "diffuse", texture = "../floor.png" }'),
    ("mesh", 'material = { type = "diffuse", color = [1, 1, 1] }\nshape = { type = "mesh", path = "../m.obj" }'),
])
def test_a_toml_path_may_not_leave_the_scene_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                    field: str, line: str) -> None:
    """`../../../x.png` was read from wherever it led; a glTF URI could not leave its folder."""
    (tmp_path / "floor.png").write_bytes(png_stream(4, 4))
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "scene").mkdir()
    shape = "" if field == "mesh" else 'shape = { type = "plane", size = [1.0, 1.0] }\n'
    path = tmp_path / "scene" / "s.toml"
    path.write_text(f'[[objects]]\nname = "x"\n{shape}{line}\n')
    refused(path, capsys, "expected a path inside the scene's folder or in $DEPTHIMPOSTOR_MODEL_PATH (or an absolute "
            'path), got "../', 'which leaves it')


def test_an_absolute_toml_path_is_still_read(tmp_path: Path) -> None:
    (tmp_path / "floor.png").write_bytes(png_stream(4, 4))
    (tmp_path / "scene").mkdir()
    assert load_scene(textured_scene(tmp_path / "scene", str(tmp_path / "floor.png"))).textures


@pytest.mark.parametrize("uri, fragment", [
    ("../y.png", 'expected a file in the glTF file\'s folder or below it (in {folder}), got "../y.png", which leaves it'),
    ("sub/../../y.png", 'expected a file in the glTF file\'s folder or below it (in {folder}), got "sub/../../y.png", '
                        "which leaves it"),
    ("{absolute}", "expected a data: URI or a path relative to the glTF file, got"),
    ("file:///etc/passwd", 'expected a data: URI or a path relative to the glTF file, got "file:///etc/passwd"'),
])
def test_a_gltf_uri_may_not_leave_its_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str], uri: str,
                                             fragment: str) -> None:
    """The refusal names the rule (it said 'an image trimesh can decode (PNG or JPEG)')."""
    (tmp_path / "y.png").write_bytes(png_stream(4, 4))
    folder = tmp_path / "model"
    folder.mkdir()
    uri = uri.format(absolute=tmp_path / "y.png")
    refused(gltf_with_image(folder, {"uri": uri}), capsys, "images[0].uri: " + fragment.format(folder=folder))


# --- item 12: tracebacks from the JSON and the buffers ------------------------------------------------------


def mutated(tmp_path: Path, change: str) -> Path:
    w = box_writer()
    primitive = w.json["meshes"][0]["primitives"][0]
    if change == "negative_count":
        w.json["accessors"][0]["count"] = -5
    elif change == "index_past_vertices":
        primitive["indices"] = w.accessor(np.array([0, 1, 99]), "SCALAR")
    elif change in ("lights_number", "lights_object"):
        w.json["extensions"] = {"KHR_lights_punctual": {"lights": 5 if change == "lights_number" else {"a": 1}}}
        w.json["nodes"][0]["extensions"] = {"KHR_lights_punctual": {"light": 0}}
    elif change == "mode_array":
        primitive["mode"] = [4]
    elif change == "long_uri":
        path = w.write(tmp_path / "x.gltf")
        text = path.read_text().replace('"uri": "x.bin"', '"uri": "' + "b" * 5000 + '.bin"')
        path.write_text(text)
        return path
    elif change == "deep_json":
        path = tmp_path / "x.gltf"
        path.write_text('{"asset": {"version": "2.0"}, "extras": ' + "[" * 100000 + "]" * 100000 + "}")
        return path
    elif change == "view_past_buffer":
        w.json["bufferViews"][0]["byteLength"] = 10**6
    elif change == "short_data_uri":
        path = w.write(tmp_path / "x.gltf")
        text = path.read_text().replace('"uri": "x.bin"', '"uri": "data:application/octet-stream;base64,AAAA"')
        path.write_text(text)
        return path
    elif change == "stride_1000":
        w.json["bufferViews"][0]["byteStride"] = 1000
    return w.write(tmp_path / "x.glb")


@pytest.mark.parametrize("change, fragments", [
    ("negative_count", ("accessors[0].count: expected a whole number >= 0, got -5",)),
    ("index_past_vertices", ("meshes[0].primitives[0].indices: expected vertex indices below the POSITION count 8, "
                             "got 99",)),
    ("lights_number", ("extensions.KHR_lights_punctual.lights: expected an array, got 5",)),
    ("lights_object", ("extensions.KHR_lights_punctual.lights: expected an array, got {a = 1}",)),
    ("mode_array", ("meshes[0].primitives[0].mode: expected a primitive mode 0 to 6, got [4]",)),
    ("long_uri", ("buffers[0].uri: expected a file next to the glTF file, got", "File name too long")),
    ("deep_json", ("expected glTF JSON, got arrays or objects nested too deep to read",)),
    ("view_past_buffer", ("bufferViews[0]: expected a range within its buffer of", "got bytes 0 to 1000000")),
    ("short_data_uri", ("buffers[0]: expected", "bytes (byteLength), got 3")),
    ("stride_1000", ("bufferViews[0].byteStride: expected a number of bytes in [4, 252], got 1000",)),
])
def test_a_broken_gltf_is_one_line_not_a_traceback(tmp_path: Path, capsys: pytest.CaptureFixture[str], change: str,
                                                   fragments: tuple[str, ...]) -> None:
    refused(mutated(tmp_path, change), capsys, *fragments)


def test_a_gltf_mesh_shape_is_read_by_the_same_reader(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`shape = { type = "mesh", path = "x.gltf" }` went to trimesh, whose walk of a chain of nodes
    is quadratic (3 x 10^4 nodes: 55 s) and which checks no count before decoding: it is read as
    the `gltf` shape is, its world-space parts one mesh (a box at the end of 30,000 nodes here)."""
    calls = counting_node_matrices(monkeypatch)
    write_chain(tmp_path, 30000, moved=True)
    (tmp_path / "s.toml").write_text('[[objects]]\nname = "box"\nshape = { type = "mesh", path = "chain.gltf" }\n'
                                     'material = { type = "diffuse", color = [1, 1, 1] }\n')
    mesh = scene_geometry(load_scene(tmp_path / "s.toml").objects)[0].world_mesh
    assert len(calls) == 30000
    assert len(mesh.indices) == 12 and np.allclose(np.ptp(mesh.positions, axis=0), 1.0)


def test_texture_coordinates_that_are_not_finite_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Found by the fuzzer: a TEXCOORD_0 of NaN (a view's offset removed, floats read from other
    bytes) was a ValueError from the mesh's own check."""
    w = GltfWriter()
    w.node(mesh=w.mesh(w.primitive(TRIANGLE, uvs=[[0.0, 0.0], [float("nan"), 0.0], [0.0, 1.0]], material=w.material("M"))))
    refused(w.write(tmp_path / "x.glb"), capsys, "meshes[0].primitives[0].attributes.TEXCOORD_0: expected finite "
            "texture coordinates, got NaN or infinity")


def test_a_texture_mean_takes_no_float_copy_of_the_image(monkeypatch: pytest.MonkeyPatch) -> None:
    """Found by the fuzzer: a 255 x 18861 texture took 440 MB to load, its mean colour taken over a
    float64 copy of every texel and four temporaries (an 8192^2 one: 6 GB). The mean is the same."""
    from depthimpostor import textures

    pixels = (np.random.default_rng(1).random((300, 200, 4)) * 255).astype(np.uint8)
    expected = textures.srgb_to_linear(pixels[..., :3].reshape(-1, 3) / 255.0).mean(axis=0)

    def no_copies(values: np.ndarray) -> np.ndarray:
        assert values.size <= 256, "a decoded copy of the image"
        return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)

    monkeypatch.setattr(textures, "srgb_to_linear", no_copies)
    assert np.allclose(textures.texture_from_pixels(pixels, {}).mean_color, expected, rtol=1e-12, atol=0)
