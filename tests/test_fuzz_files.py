"""The file fuzzer: mutations of valid glTF files and image headers (tests/fuzz_files.py), each
rendered by a worker process apart (tests/fuzz_worker.py). The property, for every input: a frame
(finite, no GL error left) or a refusal in one line (a DepthImpostorError of exit code 2, what the
CLI prints as `depthimpostor: ...` and exits 2 with), never another exception, nothing else
written by a library, no answer later than HANG_SECONDS (a hang, not a timing: a case takes a
fraction of a second), and a peak memory within the budgets: the issue's 500 MB for a refusal,
the loader's MAX_DECODED_BYTES and as much again for a frame.

A fixed, small budget in CI (EXAMPLES cases a test, drawn from a fixed seed: `derandomize`, so
every run tries the same files); DEPTHIMPOSTOR_FUZZ_EXAMPLES=1500 runs more, as docs/bad_inputs.md
reports (DEPTHIMPOSTOR_FUZZ_LOG=file.jsonl keeps every outcome).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from depthimpostor.scene.gltf import MAX_DECODED_BYTES
from fuzz_files import (
    HOSTILE_VALUES, TEXTURED_SCENE, Result, Worker, gltf_seed, locations, mutate_bytes, mutate_json, sky_seed,
    texture_seed, with_png_header, with_size_fields, with_sky_size, write_gltf,
)

EXAMPLES = int(os.environ.get("DEPTHIMPOSTOR_FUZZ_EXAMPLES", "40"))
LOG = os.environ.get("DEPTHIMPOSTOR_FUZZ_LOG", "")
HANG_SECONDS = 60.0
MB = 10**6
REFUSAL_MEMORY = 500 * MB
FRAME_MEMORY = MAX_DECODED_BYTES + REFUSAL_MEMORY

FUZZ = settings(max_examples=EXAMPLES, derandomize=True, database=None, deadline=None, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                       HealthCheck.data_too_large])

SEED = gltf_seed()
SEED_JSON: dict[str, Any] = json.loads(json.dumps(SEED.json))
BLOB, IMAGE = bytes(SEED.blob), texture_seed("png")
PLACES = sorted(set(locations(SEED_JSON)), key=repr)


@pytest.fixture(scope="module")
def worker() -> Iterator[Worker]:
    """The worker, warmed on a valid file (its first frame compiles the shaders)."""
    running = Worker()
    with tempfile.TemporaryDirectory() as folder:
        warm = running.run(write_gltf(SEED_JSON, BLOB, IMAGE, Path(folder), "glb"), timeout=600.0)
    assert warm.outcome == "rendered", warm.message
    yield running
    running.release()


def check(result: Result, path: Path) -> None:
    if LOG:  # what a long run tried, for docs/bad_inputs.md
        with open(LOG, "a", encoding="utf-8") as log:
            log.write(json.dumps({"outcome": result.outcome, "message": result.message.replace(str(path.parent), ""),
                                  "growth": result.growth}) + "\n")
    assert result.outcome in ("rendered", "refused"), f"{result.outcome} for {path.name}: {result.message}"
    assert result.stray == 0, f"{result.stray} bytes written besides the one line: see the worker's log"
    if result.outcome == "refused":
        assert "\n" not in result.message and result.message, result.message
        assert result.growth <= REFUSAL_MEMORY, f"{result.growth / MB:.0f} MB to refuse: {result.message}"
    else:
        assert result.growth <= FRAME_MEMORY, f"{result.growth / MB:.0f} MB for a frame"


path_in_json = st.sampled_from(PLACES)
json_mutation = st.one_of(
    st.tuples(st.just("set"), path_in_json, st.one_of(st.sampled_from(HOSTILE_VALUES), st.integers(-(2**40), 2**40))),
    st.tuples(st.just("nudge"), path_in_json, st.sampled_from([-1, 1, 2, 3, -3, 2**20, 1000.0, -1.0, 1e-9, 1e30])),
    st.tuples(st.just("delete"), path_in_json),
    st.tuples(st.just("repeat"), path_in_json),
)
byte_mutation = st.tuples(st.sampled_from(["flip", "cut"]), st.integers(0, 2**20), st.integers(0, 255))


@FUZZ
@given(json_ops=st.lists(json_mutation, max_size=3), blob_ops=st.lists(byte_mutation, max_size=2),
       image_ops=st.lists(byte_mutation, max_size=2), container=st.sampled_from(["glb", "gltf", "data"]))
def test_mutated_gltf_files_render_or_are_refused_in_one_line(
        worker: Worker, json_ops: list[tuple[Any, ...]], blob_ops: list[tuple[Any, ...]],
        image_ops: list[tuple[Any, ...]], container: str) -> None:
    document = json.loads(json.dumps(SEED_JSON))
    for op in json_ops:
        mutate_json(document, op)
    blob, image = BLOB, IMAGE
    for op in blob_ops:
        blob = mutate_bytes(blob, op)
    for op in image_ops:
        image = mutate_bytes(image, op)
    with tempfile.TemporaryDirectory() as folder:
        path = write_gltf(document, blob, image, Path(folder), container)
        check(worker.run(path, HANG_SECONDS), path)


side = st.one_of(st.sampled_from([0, 1, 2, 8, 255, 8192, 8193, 16384, 16385, 65535, 2**31 - 1, 2**32 - 1]),
                 st.integers(0, 2**32 - 1))


@FUZZ
@given(texture=st.sampled_from(["png", "jpeg", "bmp", "gif"]), width=side, height=side,
       depth=st.sampled_from([1, 2, 4, 8, 16, 3, 0, 255]), colour=st.sampled_from([0, 2, 3, 4, 6, 1, 5, 7]),
       crc=st.booleans(), resize=st.booleans(), sky=st.sampled_from(["hdr", "exr"]),
       box=st.tuples(st.integers(-2**31, 2**31 - 1), side, side, side), resize_sky=st.sampled_from([False, False, True]),
       texture_ops=st.lists(byte_mutation, max_size=2), sky_ops=st.lists(byte_mutation, max_size=1))
def test_image_headers_that_lie_are_refused_before_decoding_or_read(
        worker: Worker, texture: str, width: int, height: int, depth: int, colour: int, crc: bool,
        resize: bool, sky: str, box: tuple[int, int, int, int], resize_sky: bool,
        texture_ops: list[tuple[Any, ...]], sky_ops: list[tuple[Any, ...]]) -> None:
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        floor = texture_seed(texture)
        if resize:
            floor = with_png_header(floor, width, height, depth, colour, crc) if texture == "png" \
                else with_size_fields(floor, texture, width, height)
        environment = sky_seed(sky, folder)
        if resize_sky:
            environment = with_sky_size(environment, sky, box)
        for op in texture_ops:
            floor = mutate_bytes(floor, op)
        for op in sky_ops:
            environment = mutate_bytes(environment, op)
        (folder / f"floor.{texture}").write_bytes(floor)
        (folder / f"sky.{sky}").write_bytes(environment)
        path = folder / "s.toml"
        path.write_text(TEXTURED_SCENE.format(sky=sky, texture=texture))
        check(worker.run(path, HANG_SECONDS), path)
