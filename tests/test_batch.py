"""`depthimpostor batch`, `render --video --workers` and `bench --workers` on a real Ray: a
simulated cluster of two nodes on this machine (ray.cluster_utils.Cluster; one for the module: it
takes seconds to start), each node a raylet of its own with two CPUs, the module's pool of two
workers one on each. A batch draws what one process draws, bit for bit, on both nodes; a worker
killed mid-batch loses nothing and draws nothing twice, nor does a node lost mid-batch (its frames
are drawn again elsewhere); a bad job fails alone; a batch stopped half-way resumes where it
stopped. The batch file's refusals need no Ray."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import ray
from PIL import Image
from ray.cluster_utils import Cluster

from conftest import SCENES
from depthimpostor.aov import read_aovs
from depthimpostor.batch.jobs import Batch, Frame, load_batch
from depthimpostor.batch.run import LocalPool, RayPool, open_pool, recorded_outputs, run_batch
from depthimpostor.batch.worker import KEPT_RENDERERS, FrameWorker
from depthimpostor.bench import COLUMNS
from depthimpostor.cli import main
from depthimpostor.errors import SceneError

WORKERS = 2

pytestmark = pytest.mark.xdist_group("ray")
ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # one pytest process holds the Ray (pyproject's --dist loadgroup)


@pytest.fixture(scope="module")
def cluster() -> Iterator[Cluster]:
    """Two nodes: room on each for one worker of the module's pool and one of a command's own pool
    beside it (each worker asks for a CPU). It costs about what a one-node `ray.init` costs: the
    second node's raylet starts in a few seconds beside the head's services."""
    nodes = Cluster(initialize_head=True, head_node_args={"num_cpus": WORKERS, "include_dashboard": False})
    nodes.add_node(num_cpus=WORKERS)
    ray.init(address=nodes.address, logging_level="ERROR")
    nodes.wait_for_nodes()
    yield nodes
    ray.shutdown()
    nodes.shutdown()


@pytest.fixture(scope="module")
def pool(cluster: Cluster) -> Iterator[RayPool]:
    """Two workers for the module's batches, one per node (RayPool spreads them): each keeps its
    context and renderers between tests."""
    with RayPool(WORKERS) as workers:
        yield workers


def _batch(folder: Path, frames: int = 6, extra: str = "") -> Batch:
    folder.mkdir(parents=True, exist_ok=True)
    jobs = folder / "jobs.toml"
    jobs.write_text(f"""\
[defaults]
size = [64, 36]

[[jobs]]
name = "orbit"
scene = "{SCENES / 'default.toml'}"
frames = {frames}
camera_path = "orbit"
aov = ["reflector_id", "object_id", "depth"]
output = "out/{{job}}/{{frame:03d}}.png"

[[jobs]]
name = "views"
scene = "{SCENES / 'two_mirrors.toml'}"
times = [0.0]
cameras = [{{ eye = [0.0, 1.5, 5.0], target = [0.0, 1.0, 0.0] }}, {{ eye = [2.0, 2.0, 4.0], target = [0.0, 0.5, 0.0] }}]
output = "out/{{job}}/{{frame}}.png"
{extra}""")
    return load_batch(jobs)


def _pictures(folder: Path) -> dict[str, np.ndarray]:
    found: dict[str, np.ndarray] = {}
    for path in sorted((folder / "out").rglob("*.png")):
        found[str(path.relative_to(folder))] = np.asarray(Image.open(path))
    for path in sorted((folder / "out").rglob("*.exr")):
        for name, channel in read_aovs(path).items():
            found[f"{path.relative_to(folder)}:{name}"] = channel
    return found


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> dict[str, np.ndarray]:
    """The reference: every frame drawn in order, in this process, by one worker."""
    folder = tmp_path_factory.mktemp("serial")
    batch = _batch(folder)
    with LocalPool() as local:
        summary = run_batch(batch.frames, local, batch.manifest, progress=False)
    assert summary.rendered == len(batch.frames) == 8 and not summary.failed
    return _pictures(folder)


def _manifest(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_a_batch_on_two_workers_equals_the_serial_run(pool: RayPool, serial: dict[str, np.ndarray], tmp_path: Path) -> None:
    batch = _batch(tmp_path)
    summary = run_batch(batch.frames, pool, batch.manifest, progress=False)
    assert summary.rendered == 8 and summary.found == 0 and not summary.failed
    drawn = _pictures(tmp_path)
    assert drawn.keys() == serial.keys()
    for name, image in serial.items():
        assert np.array_equal(drawn[name], image), name  # bit for bit
    records = _manifest(batch.manifest)
    assert len({record["worker"]["pid"] for record in records}) == WORKERS  # both workers drew
    assert {record["worker"]["node"] for record in records} == _alive_nodes()  # on both nodes
    assert sorted((r["job"], r["frame"]) for r in records) == sorted((f.job, f.index) for f in batch.frames)
    drawn_record = next(r for r in records if r["job"] == "orbit")
    assert drawn_record["status"] == "rendered" and drawn_record["figures"]["stand_in"].startswith("5 depth images")
    assert set(drawn_record["seconds"]) == {"setup", "draw", "aov", "write"}
    # A rerun finds every frame complete and listed: nothing drawn, nothing added to the manifest.
    again = run_batch(batch.frames, pool, batch.manifest, progress=False)
    assert again.rendered == 0 and again.found == 8
    assert len(_manifest(batch.manifest)) == 8


def test_a_worker_killed_mid_batch_loses_nothing(pool: RayPool, serial: dict[str, np.ndarray], tmp_path: Path) -> None:
    batch = _batch(tmp_path, extra='\n[[jobs]]\nname = "more"\nscene = "' + str(SCENES / "default.toml")
                   + '"\nframes = 10\noutput = "out/{job}/{frame:03d}.png"\n')
    before = set(ray.get([actor.pid.remote() for actor in pool.actors]))
    killed: list[int] = []

    def kill_once(record: dict[str, Any]) -> None:
        if not killed:  # the worker that drew the first frame dies while it holds more
            killed.append(record["worker"]["pid"])
            os.kill(killed[0], signal.SIGKILL)

    summary = run_batch(batch.frames, pool, batch.manifest, progress=False, on_record=kill_once)
    assert not summary.failed
    assert all(path.is_file() for frame in batch.frames for path in frame.outputs)
    records = _manifest(batch.manifest)
    by_output: dict[str, list[str]] = {}
    for record in records:
        by_output.setdefault(record["outputs"][0], []).append(record["status"])
    assert len(by_output) == len(batch.frames)  # every frame listed
    assert all(statuses.count("rendered") <= 1 and len(statuses) == 1 for statuses in by_output.values())
    # The killed worker was restarted (a new process), and drew the frames it held when it died.
    assert {record["worker"]["pid"] for record in records} - before
    drawn = _pictures(tmp_path)
    for name, image in serial.items():
        assert np.array_equal(drawn[name], image), name


def test_a_bad_job_fails_alone(pool: RayPool, tmp_path: Path) -> None:
    batch = _batch(tmp_path, frames=2, extra='\n[[jobs]]\nname = "bad"\nscene = "missing.toml"\nframes = 3\n'
                                              'output = "out/{job}/{frame}.png"\n')
    summary = run_batch(batch.frames, pool, batch.manifest, progress=False)
    assert summary.rendered == 4
    assert summary.failed_jobs() == {"bad": (3, f"{tmp_path / 'missing.toml'}: no such file")}
    failed = [r for r in _manifest(batch.manifest) if r["status"] == "failed"]
    assert len(failed) == 3 and all("\n" not in r["error"] for r in failed)
    # Its frames were not written, and a rerun tries them again (and them alone).
    again = run_batch(batch.frames, pool, batch.manifest, progress=False)
    assert again.rendered == 0 and again.found == 4 and len(again.failed) == 3


def test_a_stopped_batch_resumes_where_it_stopped(pool: RayPool, tmp_path: Path) -> None:
    """The driver stopped half-way (Ctrl-C): the rerun draws what is missing, once each."""
    batch = _batch(tmp_path, frames=8)

    def stop_after_three(record: dict[str, Any]) -> None:
        if len(_manifest(batch.manifest)) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_batch(batch.frames, pool, batch.manifest, progress=False, on_record=stop_after_three)
    first = recorded_outputs(batch.manifest)
    summary = run_batch(batch.frames, pool, batch.manifest, progress=False)
    assert not summary.failed and summary.rendered + summary.found == 10 and summary.rendered <= 7
    records = _manifest(batch.manifest)
    colours = [r["outputs"][0] for r in records]
    assert len(colours) == len(set(colours)) == 10  # each frame once, none missing
    assert {str(p) for p in batch.frames[0].outputs} <= first | recorded_outputs(batch.manifest)


def _alive_nodes() -> set[str]:
    return {node["NodeID"] for node in ray.nodes() if node["Alive"]}


def test_a_video_on_two_workers_equals_the_serial_video(cluster: Cluster, tmp_path: Path) -> None:
    arguments = [str(SCENES / "default.toml"), "--size", "64x36", "--duration", "0.4", "--fps", "20"]
    assert main(["render", *arguments, "--video", str(tmp_path / "serial.gif")]) == 0
    assert main(["render", *arguments, "--video", str(tmp_path / "workers.gif"), "--workers", "2"]) == 0
    assert (tmp_path / "workers.gif").read_bytes() == (tmp_path / "serial.gif").read_bytes()


#: bench's columns that are timings (each worker's own): every other column is an accuracy figure.
TIMINGS = ("frame_ms_median", "frame_ms_p10", "frame_ms_p90", "mirror_pass_ms_median", "gl_time_query_ms",
           "gl_mirror_pass_ms", "bake_ms_median")


def _bench_csv(folder: Path) -> tuple[list[str], list[dict[str, str]]]:
    lines = (folder / "bench.csv").read_text(encoding="utf-8").splitlines()
    comments = [line for line in lines if line.startswith("# ")]
    return comments, list(csv.DictReader(line for line in lines if not line.startswith("# ")))


def test_a_bench_on_two_workers_has_the_serial_accuracy(cluster: Cluster, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """Three configurations on two workers (one of them measures two, reusing its truth of the
    scene): the error columns equal the serial bench's exactly; the timings are there and finite."""
    arguments = ["bench", str(SCENES / "default.toml"), "--methods", "depth,hybrid,raytrace", "--algorithms",
                 "optimized", "--resolutions", "16", "--size", "64x36", "--frames", "2", "--warmup", "0", "--bakes", "1"]
    assert main([*arguments, "-o", str(tmp_path / "serial")]) == 0
    assert main([*arguments, "-o", str(tmp_path / "workers"), "--workers", "2"]) == 0
    assert "workers: 2 Ray workers on a local Ray" in capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "workers").iterdir()) == sorted(p.name for p in (tmp_path / "serial").iterdir())
    serial_header, serial = _bench_csv(tmp_path / "serial")
    header, rows = _bench_csv(tmp_path / "workers")
    assert list(rows[0]) == COLUMNS and len(rows) == len(serial) == 3
    assert header[1:-1] == serial_header[1:] and header[-1].startswith("# workers: 2 Ray workers")
    for row, alone in zip(rows, serial, strict=True):
        assert {k: v for k, v in row.items() if k not in TIMINGS} == {k: v for k, v in alone.items() if k not in TIMINGS}
        assert all(math.isfinite(float(row[name])) and float(row[name]) >= 0 for name in TIMINGS), row
        assert float(row["frame_ms_median"]) > float(row["mirror_pass_ms_median"]) > 0
    assert "| default | `depth` optimized | 16 |" in (tmp_path / "workers" / "bench.md").read_text()


def test_a_configuration_over_its_workers_memory_stops_the_bench_in_one_line(tmp_path: Path,
                                                                             capsys: pytest.CaptureFixture[str]) -> None:
    """Each configuration is checked against its worker's context (--workers 0: this process's)."""
    assert main(["bench", str(SCENES / "default.toml"), "--methods", "depth", "--algorithms", "optimized",
                 "--resolutions", "512", "--size", "64x36", "--frames", "1", "--warmup", "0", "--bakes", "1",
                 "--max-memory", "1M", "--workers", "0", "-o", str(tmp_path)]) == 1
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("depthimpostor: bench: default, depth optimized, resolution 512: ") and "MiB" in error
    assert list(tmp_path.iterdir()) == []


def test_bench_on_workers_refuses_peers(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", str(SCENES / "default.toml"), "--peers", "--workers", "2"]) == 2
    assert "command line: --peers: expected without --workers" in capsys.readouterr().err


@pytest.mark.parametrize(("extra", "message"), [
    ('size = [64, 36]\n', "jobs.toml: jobs[0].name: missing required field"),
    ('name = "a"\nscene = "s.toml"\noutput = "x.png"\nframe = 3\n', 'jobs[0]: unknown field "frame"'),
    ('name = "a"\nscene = "s.toml"\noutput = "x.png"\nframes = 3\n', "expected a file name per frame"),
    ('name = "a"\nscene = "s.toml"\noutput = "{jobs}.png"\n', "jobs[0].output: expected a template of the fields"),
    ('name = "a"\nscene = "s.toml"\noutput = "{frame}.png"\ntimes = [0, 1]\ncameras = [{eye = [0, 0, 1]}, '
     '{eye = [0, 0, 2]}, {eye = [0, 0, 3]}]\n', "jobs[0].times: expected 1 or 3 values"),
    ('name = "a"\nscene = "s.toml"\noutput = "{frame}.png"\ntimes = [0]\nframes = 2\n',
     "jobs[0].frames: expected no value beside times or cameras"),
    ('name = "a"\nscene = "s.toml"\noutput = "{frame}.png"\nmethod = "mirror"\n', "jobs[0].method: expected one of: depth"),
    ('name = "a"\nscene = "s.toml"\noutput = "{frame}.png"\naov = ["mask"]\n', "jobs[0].aov: expected AOVs among depth"),
    ('name = "a\n', "jobs.toml: expected a TOML batch file, got "),
])
def test_a_bad_batch_file_is_refused_in_one_line(tmp_path: Path, extra: str, message: str) -> None:
    jobs = tmp_path / "jobs.toml"
    jobs.write_text("[[jobs]]\n" + extra)
    with pytest.raises(SceneError) as raised:
        load_batch(jobs)
    assert message in str(raised.value) and "\n" not in str(raised.value)


def test_batch_command_reports_a_failed_job_in_one_line(cluster: Cluster, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    jobs = tmp_path / "jobs.toml"
    jobs.write_text(f'[[jobs]]\nname = "good"\nscene = "{SCENES / "default.toml"}"\nsize = [32, 18]\n'
                    'output = "good.png"\n\n[[jobs]]\nname = "bad"\nscene = "nothing.toml"\noutput = "bad.png"\n')
    assert main(["batch", str(jobs), "--workers", "2"]) == 1
    out, err = capsys.readouterr()
    assert "2 frames: 1 rendered, 0 complete before, 1 failed" in out
    assert err.strip().splitlines()[-1] == f"depthimpostor: batch: job bad: 1 frame failed: {tmp_path / 'nothing.toml'}: no such file"
    assert (tmp_path / "good.png").is_file() and (tmp_path / "jobs.manifest.jsonl").is_file()


def test_a_video_whose_method_refuses_the_scene_is_refused_before_any_worker(tmp_path: Path,
                                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """As the serial video: one line, exit 2, no file, and no Ray needed (refused before it starts)."""
    video = tmp_path / "v.gif"
    assert main(["render", str(SCENES / "two_mirrors.toml"), "--size", "32x18", "--duration", "0.1", "--video",
                 str(video), "--method", "raytrace", "--workers", "2"]) == 2
    assert "max_bounces: expected 1 with --method raytrace" in capsys.readouterr().err
    assert not video.exists() and list(tmp_path.iterdir()) == []


def test_a_worker_keeps_its_most_recently_used_renderers(tmp_path: Path) -> None:
    """Frames of six settings: each gets a renderer, the four most recent are kept (no Ray needed)."""
    def frame(k: int, name: str) -> Frame:
        return Frame("sizes", k, str(SCENES / "default.toml"), "depth", "optimized", (("size", (32 + 2 * k, 18)),), 0.0,
                     None, (), str(tmp_path / f"{name}.png"))

    worker = FrameWorker()
    try:
        made = [worker.render(frame(k, str(k))) for k in range(6)]
        assert all(r["status"] == "rendered" and r["seconds"]["setup"] > 0 for r in made)
        assert worker.kept == KEPT_RENDERERS == 4
        assert worker.render(frame(5, "again5"))["seconds"]["setup"] == 0  # kept: drawn with it
        assert worker.render(frame(0, "again0"))["seconds"]["setup"] > 0  # let go: made anew
        assert worker.kept == 4
        assert np.array_equal(np.asarray(Image.open(tmp_path / "again0.png")), np.asarray(Image.open(tmp_path / "0.png")))
    finally:
        worker.release()


def test_workers_need_ray_and_an_address_needs_workers(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(SceneError, match=r"command line: --address: expected with --workers 1 or more"):
        open_pool(0, "auto")
    monkeypatch.setitem(sys.modules, "ray", None)  # as where the [batch] extra is not installed
    with pytest.raises(SceneError, match=r'--workers: expected Ray to be installed: pip install "depthimpostor\[batch\]"'):
        open_pool(2, None)
