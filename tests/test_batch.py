"""Batch drapes on Ray (sandbox/batch, ``python -m sandbox batch``).

Fast: the spec and its one-line errors, random bodies, the gates against the acceptance,
task folders written whole, the manifest, and the scheduler (retries, hard limits, resume)
on a fake pool. Slow (drapes on local Ray, 4 cm meshes, short time limits, no
self-collision: about 15 s a drape on one thread): a 6-task batch with its manifest and
folders, resuming after a task folder was deleted, bit-identical positions on 1 and 2
workers, a worker killed mid-task, and a two-node cluster on this machine.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import time
from pathlib import Path

import pytest

from sandbox.batch import load, load_spec, manifest, store
from sandbox.batch.gates import GATES, GateThresholds, failed_gates
from sandbox.batch.pool import Finished
from sandbox.batch.run import run_batch
from sandbox.batch.spec import expand_tasks, random_bodies
from sandbox.cli import main
from sandbox.errors import SandboxError
from sandbox.garment.config import AcceptanceConfig
from sandbox.garment.metrics import meets_acceptance

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "batch_small.toml"

TINY = """
name = "tiny"
garments = [{garments}]
edge_cm = 4.0
wall_limit_s = 300.0
render = {render}
[bodies]
sizes = [{sizes}]
{random}
[drape]
time_limit_s = 0.5
min_time_s = 0.2
self_collision = false
[drape.sewing]
time_limit_s = 0.5
self_collision = false
"""
"""A batch of cheap drapes: 4 cm, half a second sewn and draped, no self-collision."""


def tiny_spec(tmp_path: Path, name: str = "tiny.toml", *, garments=("camisole", "tank-top"),
              sizes=(10, 14), random: bool = True, render: bool = True, extra: str = "",
              tail: str = "") -> Path:  # fmt: skip
    text = TINY.format(garments=", ".join(f'"{g}"' for g in garments),
                       sizes=", ".join(map(str, sizes)), render=str(render).lower(),
                       random="random = { count = 1, seed = 3 }" if random else "")  # fmt: skip
    path = tmp_path / name
    path.write_text(extra + text + tail)
    return path


# ------------------------------------------------------------------------------ spec
def test_the_example_spec_gives_six_tasks_with_stable_ids():
    spec = load_spec(EXAMPLE)
    tasks = expand_tasks(spec)
    assert spec.task_count == len(tasks) == 6
    assert [t.garment.label for t in tasks[:3]] == ["tank-top"] * 3
    assert [t.body.label for t in tasks[:3]] == ["size10", "size14", "client-a"]
    assert len({t.task_id for t in tasks}) == 6
    assert [t.task_id for t in expand_tasks(load_spec(EXAMPLE))] == [t.task_id for t in tasks]
    t = tasks[2]
    assert t.edge_m == pytest.approx(0.03) and t.config.wall_limit_s == 600.0
    assert t.body.measurements()["bust_girth"] == 94.0  # the rest from size 12
    assert t.config.acceptance == AcceptanceConfig()  # the gates' defaults


def test_a_setting_that_shapes_the_drape_changes_the_task_id(tmp_path):
    a = expand_tasks(load_spec(tiny_spec(tmp_path)))
    b = expand_tasks(load_spec(tiny_spec(tmp_path, "b.toml", extra="retries = 0\n")))
    c = expand_tasks(load_spec(tiny_spec(tmp_path, "c.toml", tail="[gates]\nseam_gap_m = 0.003\n")))
    assert [t.task_id for t in a] == [t.task_id for t in b]  # retries: not an output
    assert not {t.task_id for t in a} & {t.task_id for t in c}


BAD_SPECS = [
    ("colour = 1\n", "colour: unknown key"),
    ('garments = ["tank-top"]\n', "bodies: missing"),
    ('garments = ["tshirt"]\n[bodies]\nsizes = [12]\n', "garments[0]: unknown garment 'tshirt'"),
    ('garments = ["nope.json"]\n[bodies]\nsizes = [12]\n', "garments[0]:"),
    ('garments = "all"\n[bodies]\nsizes = [13]\n', "bodies.sizes[0]: 13 is not a database size"),
    ('garments = "all"\n[bodies]\n', "bodies: no body"),
    ('garments = "all"\nedge_cm = -1\n[bodies]\nsizes = [12]\n', "edge_cm: must be a positive"),
    ('garments = "all"\nedge_cm = [3, "x"]\n[bodies]\nsizes = [12]\n', "edge_cm[1]: must be"),
    ('garments = "all"\nintegrator = "rk4"\n[bodies]\nsizes = [12]\n', "integrator: 'rk4' is"),
    ('garments = "all"\nfabrics = ["velvet"]\n[bodies]\nsizes = [12]\n', "fabrics[0]:"),
    ('garments = "all"\nretries = -1\n[bodies]\nsizes = [12]\n', "retries: must be a whole"),
    ('garments = "all"\nrender = "yes"\n[bodies]\nsizes = [12]\n', "render: must be true or"),
    ('garments = "all"\nwall_limit_s = 100\nkill_after_s = 50\n[bodies]\nsizes = [12]\n',
     "kill_after_s: 50 s is shorter"),
    ('garments = "all"\n[bodies]\nsizes = [12]\n[gates]\nseam_gap = 1\n',
     "gates.seam_gap: unknown threshold"),
    ('garments = "all"\n[bodies]\nsizes = [12]\n[gates]\npenetration_m = -1\n',
     "gates.penetration_m: must be a positive number"),
    ('garments = "all"\n[bodies]\nsizes = [12]\n[drape]\nintegrator = "implicit_euler"\n',
     "drape.integrator: set by the top-level integrator"),
    ('garments = "all"\n[bodies]\nsizes = [12]\n[drape]\ntime_limit = 4\n',
     "drape: unknown setting(s) time_limit"),
    ('garments = "all"\n[bodies]\n[[bodies.measured]]\nbust_girth = 300\n',
     "bodies.measured[0]: measurements: bust_girth=300 cm is outside"),
    ('garments = "all"\n[bodies]\n[[bodies.measured]]\nbust = 90\n',
     "bodies.measured[0].bust: unknown key"),
    ('garments = "all"\n[bodies]\nrandom = { count = 2 }\n', "bodies.random.seed: missing"),
    ('garments = "all"\n[bodies]\nrandom = { count = 2, seed = 1, spread = 0.9 }\n',
     "bodies.random.spread: must be a number in 0-0.2"),
    ('garments = "all"\n[bodies]\nsizes = [12, 12]\n', "bodies: two bodies are called 'size12'"),
    ('garments = "all"\n[bodies]\ngarmentcode = ["none.yaml"]\n',
     "bodies.garmentcode[0]: "),
    ("garments = [\n", "not a TOML file"),
]  # fmt: skip


@pytest.mark.parametrize(("text", "message"), BAD_SPECS)
def test_a_bad_spec_is_one_line_naming_the_file_and_the_key(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(SandboxError) as err:
        load_spec(path)
    line = str(err.value)
    assert line.startswith(f"{path}: ") and message in line, line
    assert "\n" not in line


def test_the_cli_refuses_bad_input_in_one_line_and_status_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('garments = ["tshirt"]\n[bodies]\nsizes = [12]\n')
    big = tmp_path / "big.toml"
    big.write_text('garments = ["tank-top"]\nedge_cm = 0.2\n[bodies]\nsizes = [12]\n')
    cases = [
        (["batch", str(bad), "--out", str(tmp_path / "o")], "unknown garment 'tshirt'"),
        (["batch", str(tmp_path / "none.toml"), "--out", str(tmp_path / "o")], "no such batch"),
        (["batch", str(EXAMPLE)], "--out DIR is required"),
        (["batch"], "give a spec file"),
        (["batch", str(EXAMPLE), "--out", str(tmp_path / "o"), "--workers", "0"], "at least 1"),
        (["batch", "--report", str(tmp_path / "none")], "no such folder"),
        (["batch", "--report", str(tmp_path)], "not a batch folder"),
        (
            ["batch", str(EXAMPLE), "--out", str(tmp_path / "o"), "--address", "127.0.0.1:1"],
            "--address 127.0.0.1:1: nothing answers there",
        ),
        (
            ["batch", str(EXAMPLE), "--out", str(tmp_path / "o"), "--address", "nohost"],
            "give HOST:PORT",
        ),
        (["batch", str(big), "--out", str(tmp_path / "o")], "drape.limits: tank-top at 0.2 cm"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("error: ") and message in err and "\n" not in err, err
        assert "Traceback" not in err
    assert not (tmp_path / "o").exists()  # nothing started


def test_dry_run_prints_the_task_count_and_an_estimate(tmp_path, capsys):
    assert main(["batch", str(EXAMPLE), "--out", str(tmp_path / "o"), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "= 6 tasks" in out and "6 to run (0 done)" in out
    assert "estimated wall time" in out and "drapes/hour" in out
    assert not (tmp_path / "o").exists()


def test_a_garmentcode_body_file_is_a_body(tmp_path):
    body = Path(__file__).parent / "data" / "garmentcode" / "bodies" / "mean_all.yaml"
    path = tmp_path / "gc.toml"
    path.write_text(f'garments = ["tank-top"]\n[bodies]\ngarmentcode = ["{body}"]\n')
    (b,) = load_spec(path).bodies
    assert (b.label, b.size, b.kind) == ("mean_all", 18, "garmentcode")
    assert b.measurements()["bust_girth"] == 99.8407


def test_random_bodies_are_reproducible_and_supported():
    from sandbox.mannequin.measurements import Measurements, validate

    a, b = random_bodies(12, seed=7), random_bodies(12, seed=7)
    assert a == b and a != random_bodies(12, seed=8)
    assert len({x.measurements_cm for x in a}) == 12
    for body in a:
        validate(Measurements(**body.measurements()))  # within the supported ranges


# ----------------------------------------------------------------------------- gates
GOOD = {"converged": True, "stop_reason": "stop rule", "seam_gap_max_m": 1e-3,
        "penetration_max_m": 0.0, "body_through_cloth_max_m": 0.0,
        "intersecting_triangle_pairs": 0, "top_below_anchor_m": -0.01, "slid_off": False,
        "folded_area_pct": 0.5, "rolled_up": False, "nan_positions": 0}  # fmt: skip
BREAK = {
    "not_at_rest": {"converged": False, "stop_reason": "time limit"},
    "seams_open": {"seam_gap_max_m": 3e-3},
    "cloth_inside_body": {"penetration_max_m": 2e-3},
    "body_through_cloth": {"body_through_cloth_max_m": 5e-3},
    "intersecting_triangles": {"intersecting_triangle_pairs": 3},
    "slid_off": {"top_below_anchor_m": 0.05, "slid_off": True},
    "rolled_up": {"folded_area_pct": 4.0, "rolled_up": True},
    "nan_positions": {"nan_positions": 2},
    "time_limit": {"converged": False, "stop_reason": "wall-clock limit"},
}


def test_each_gate_rejects_its_failure_and_agrees_with_the_acceptance():
    gates = GateThresholds()
    assert failed_gates(GOOD, gates) == [] and meets_acceptance(GOOD)
    assert set(BREAK) == set(GATES)
    for gate, change in BREAK.items():
        m = {**GOOD, **change}
        assert failed_gates(m, gates) == [gate], gate
        assert not meets_acceptance(m, gates.acceptance()), gate
    assert failed_gates({**GOOD, "seam_gap_max_m": 3e-3}, GateThresholds(seam_gap_m=4e-3)) == []
    loose = GateThresholds(max_intersecting_pairs=5)
    assert failed_gates({**GOOD, "intersecting_triangle_pairs": 3}, loose) == []
    assert failed_gates(GOOD, gates, killed=True) == ["time_limit"]


# ------------------------------------------------------------------- folders, manifest
def _metrics(task_id: str, status: str = "accepted") -> dict:
    batch = {"task_id": task_id, "complete": True, "status": status, "attempts": 1,
             "gates_failed": [] if status == "accepted" else ["seams_open"],
             "timings": {"task_wall_s": 1.0}, "positions_sha256": "ab"}  # fmt: skip
    return {**GOOD, "vertex_count": 10, "fabric": "jersey", "batch": batch}


def test_a_task_folder_is_done_only_when_complete(tmp_path):
    final = store.write_task(tmp_path, "t1", _metrics("t1"), {"positions.npy": b"x"})
    assert final == tmp_path / "tasks" / "t1" and store.is_done(tmp_path, "t1")
    assert (final / "positions.npy").read_bytes() == b"x"
    # a temporary folder is not a task, and the next run removes it
    (tmp_path / "tasks" / ".tmp-t2-1-abc").mkdir()
    (tmp_path / "tasks" / ".tmp-t2-1-abc" / "metrics.json").write_text("{}")
    assert not store.is_done(tmp_path, "t2")
    assert [p.name for p in store.clean_temporary(tmp_path)] == [".tmp-t2-1-abc"]
    # a metrics.json cut short, or without its complete batch block, is not done
    (tmp_path / "tasks" / "t3").mkdir()
    (tmp_path / "tasks" / "t3" / "metrics.json").write_text('{"batch": {"task_id": "t3"')
    assert not store.is_done(tmp_path, "t3")
    (tmp_path / "tasks" / "t3" / "metrics.json").write_text('{"batch": {"task_id": "t3"}}')
    assert not store.is_done(tmp_path, "t3")
    # writing a task again replaces its folder whole
    store.write_task(tmp_path, "t1", _metrics("t1", "rejected"), {})
    assert store.read_task(final)["batch"]["status"] == "rejected"
    assert not (final / "positions.npy").exists()
    assert not [p for p in (tmp_path / "tasks").iterdir() if p.name.startswith(".")]


def test_the_manifest_is_rebuilt_from_the_folders(tmp_path):
    spec = load_spec(tiny_spec(tmp_path))
    tasks = expand_tasks(spec)
    store.write_plan(tmp_path / "o", tasks, spec.path)
    store.write_task(tmp_path / "o", tasks[0].task_id, _metrics(tasks[0].task_id), {})
    store.write_task(tmp_path / "o", tasks[1].task_id, _metrics(tasks[1].task_id, "rejected"),
                     {})  # fmt: skip
    paths = manifest.write_manifest(tmp_path / "o")
    df = load(tmp_path / "o")
    assert list(df.columns) == list(manifest.COLUMNS)
    assert list(df.status) == ["accepted", "rejected"] + ["missing"] * 4
    assert list(df.gates_failed[1]) == ["seams_open"] and bool(df.gate_seams_open[1])
    assert df.bust_girth_cm[0] == 84.0  # size 10 from the database
    lines = paths[1].read_text().splitlines()
    assert len(lines) == 6 and json.loads(lines[2])["body"] == "rand3-000"
    assert load(tmp_path / "o", rebuild=True).status.tolist() == df.status.tolist()
    manifest.remove(tmp_path / "o")  # as a run does when it starts: load() reads the folders
    assert load(tmp_path / "o").status.tolist() == df.status.tolist()


# ----------------------------------------------------------------- scheduler, fake pool
class FakePool:
    """A pool without Ray: answers each task at once, except that ``crash`` maps a task
    index to how many times its worker dies first and ``hang`` tasks never answer."""

    def __init__(self, workers=2, crash=None, hang=()):
        self.workers, self.crash, self.hang = workers, dict(crash or {}), set(hang)
        self.submitted, self.killed, self.pending = [], [], []

    def start(self):
        return self.workers

    size = property(lambda self: self.workers)

    def submit(self, slot, task):
        self.submitted.append(task.index)
        self.pending.append((slot, task))

    def wait(self, timeout_s):
        out, keep = [], []
        for slot, task in self.pending:
            if task.index in self.hang:
                keep.append((slot, task))
            elif self.crash.get(task.index, 0) > 0:
                self.crash[task.index] -= 1
                out.append(Finished(slot, task, None, "ActorDiedError: SIGKILL"))
            else:
                m = {**GOOD, "vertex_count": 10, "fabric": "jersey"}
                if task.index == 1:
                    m["seam_gap_max_m"] = 0.01
                files = {"positions.npy": b"p"}
                result = {"status": "ok", "metrics": m, "wall_s": 0.1, "files": files,
                          "positions_sha256": f"h{task.index}"}  # fmt: skip
                out.append(Finished(slot, task, result))
        self.pending = keep
        if not out:
            time.sleep(min(timeout_s, 0.05))
        return out

    def kill(self, slot):
        self.killed.append(slot)
        self.pending = [(s, t) for s, t in self.pending if s != slot]

    def close(self):
        pass


def test_a_crashed_task_is_retried_then_failed_and_a_hung_one_killed(tmp_path):
    path = tiny_spec(tmp_path, extra="retries = 1\nkill_after_s = 300\n")
    spec = dataclasses.replace(load_spec(path), kill_after_s=0.3)
    pool = FakePool(crash={2: 1, 3: 5}, hang={4})
    summary = run_batch(spec, tmp_path / "o", pool=pool, progress=False)
    df = load(tmp_path / "o")
    assert sorted(pool.submitted) == [0, 1, 2, 2, 3, 3, 4, 5]  # 2 and 3 retried once
    assert list(df.status) == ["accepted", "rejected", "accepted", "failed", "failed",
                               "accepted"]  # fmt: skip
    assert list(df.attempts) == [1, 1, 2, 2, 1, 1]
    assert "worker died 2 time(s), last: ActorDiedError" in df.error[3]
    assert df.error[4].startswith("time limit: worker killed") and list(df.gates_failed[4]) == [
        "time_limit"
    ]
    assert list(df.gates_failed[1]) == ["seams_open"] and pool.killed
    assert summary.status == {"accepted": 3, "rejected": 1, "failed": 2, "missing": 0}
    assert summary.gates["time_limit"] == 1 and summary.ran == 6
    # run again: everything is done; --retry-failed runs the two failed tasks only
    pool2 = FakePool()
    assert run_batch(spec, tmp_path / "o", pool=pool2, progress=False).ran == 0
    assert pool2.submitted == []
    pool3 = FakePool()
    run_batch(spec, tmp_path / "o", pool=pool3, progress=False, retry_failed=True)
    assert sorted(pool3.submitted) == [3, 4]
    assert set(load(tmp_path / "o").status) == {"accepted", "rejected"}


def test_a_rerun_runs_only_what_is_missing(tmp_path):
    spec = load_spec(tiny_spec(tmp_path))
    run_batch(spec, tmp_path / "o", pool=FakePool(), progress=False)
    before = load(tmp_path / "o")
    victim = before.task_id[4]
    shutil.rmtree(tmp_path / "o" / "tasks" / victim)
    (tmp_path / "o" / "tasks" / f".tmp-{victim}-1-dead").mkdir()  # a kill mid-write
    pool = FakePool()
    summary = run_batch(spec, tmp_path / "o", pool=pool, progress=False)
    assert pool.submitted == [4] and summary.ran == 1 and summary.done_before == 5
    after = load(tmp_path / "o")
    assert not [p for p in (tmp_path / "o" / "tasks").iterdir() if p.name.startswith(".")]
    assert after.drop(columns=["started_at", "finished_at", "task_wall_s"]).equals(
        before.drop(columns=["started_at", "finished_at", "task_wall_s"]))  # fmt: skip


def test_a_second_batch_in_the_same_folder_is_refused(tmp_path):
    spec = load_spec(tiny_spec(tmp_path))
    (tmp_path / "o").mkdir()
    with store.locked(tmp_path / "o"):
        with pytest.raises(SandboxError, match="another batch is running"):
            run_batch(spec, tmp_path / "o", pool=FakePool(), progress=False)


# ------------------------------------------------------------------ on Ray, with drapes
@pytest.fixture(scope="module")
def six(tmp_path_factory):
    """The 6-task batch (2 garments x 3 bodies, 4 cm) on local Ray with 2 workers."""
    tmp = tmp_path_factory.mktemp("batch")
    spec = load_spec(tiny_spec(tmp))
    summary = run_batch(spec, tmp / "out", workers=2, progress=False)
    return spec, tmp / "out", summary


@pytest.mark.slow
def test_a_six_task_batch_on_local_ray_writes_folders_and_manifest(six):
    spec, out, summary = six
    tasks = expand_tasks(spec)
    assert summary.tasks == summary.ran == 6 and summary.workers == 2
    assert summary.status["missing"] == 0 and summary.status["failed"] == 0
    assert sorted(p.name for p in (out / "tasks").iterdir()) == sorted(t.task_id for t in tasks)
    for t in tasks:
        folder = out / "tasks" / t.task_id
        names = {p.name for p in folder.iterdir()}
        want = {"metrics.json", "positions.npy", "garment.obj", "garment.mtl",
                "garment_texture.png", "garment.ply", "render.png", "render_back.png"}  # fmt: skip
        assert want <= names
        assert "body.obj" not in names and "garment.glb" not in names  # the body: body_mesh
        m = json.loads((folder / "metrics.json").read_text())
        assert m["batch"]["inputs"]["body"] == t.body.label and m["garment"] == t.garment.label
        assert m["batch"]["status"] in ("accepted", "rejected")
        assert m["batch"]["gates_failed"] == failed_gates(m, t.gates)
    df = load(out)
    assert list(df.task_id) == [t.task_id for t in tasks]
    assert df.positions_sha256.str.len().eq(64).all() and df.vertex_count.gt(100).all()
    assert df.worker_pid.nunique() == 2  # two long-lived workers shared the six tasks
    assert (out / "manifest.jsonl").read_text().count("\n") == 6
    assert json.loads((out / "summary.json").read_text())["ran"] == 6
    lines, sheets = __import__("sandbox.batch.report", fromlist=["report"]).report(out)
    assert "6 tasks" in lines[0] and any("not_at_rest" in line for line in lines)
    assert sheets and all(p.is_file() for p in sheets)


@pytest.mark.slow
def test_a_rerun_after_a_deleted_folder_drapes_only_that_task(six, tmp_path):
    spec, out, _ = six
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    before = load(copy)
    victim = before.task_id[3]
    shutil.rmtree(copy / "tasks" / victim)
    (copy / "tasks" / f".tmp-{before.task_id[5]}-9-dead").mkdir()
    summary = run_batch(spec, copy, workers=1, progress=False)
    assert summary.ran == 1 and summary.done_before == 5
    after = load(copy)
    assert list(after.positions_sha256) == list(before.positions_sha256)
    changed = after.finished_at != before.finished_at
    assert list(after.task_id[changed]) == [victim]
    assert sorted(p.name for p in (copy / "tasks").iterdir()) == sorted(before.task_id)


@pytest.mark.slow
def test_final_positions_are_bit_identical_on_one_and_two_workers(six, tmp_path):
    """Two of the six tasks, in the other order, on one worker."""
    spec, out, _ = six
    two = load(out).set_index("task_id").positions_sha256
    sub = load_spec(tiny_spec(tmp_path, garments=("tank-top", "camisole"), sizes=(14,),
                              random=False))  # fmt: skip
    run_batch(sub, tmp_path / "one", workers=1, progress=False)
    one = load(tmp_path / "one").set_index("task_id").positions_sha256
    assert len(one) == 2 and set(one.index) <= set(two.index)
    assert (one == two[one.index]).all()


def _pid_killing_pool(victim_index: int):
    from sandbox.batch.pool import RayPool

    class KillingPool(RayPool):
        """Kills the worker process running the victim task, once, a few seconds in."""

        done = False

        def submit(self, slot, task):
            import ray

            pid = ray.get(self.actors[slot].info.remote())["pid"]
            super().submit(slot, task)
            if task.index == victim_index and not self.done:
                KillingPool.done = True
                time.sleep(3.0)
                os.kill(pid, signal.SIGKILL)

    return KillingPool


@pytest.mark.slow
def test_a_killed_worker_s_task_runs_again_on_a_fresh_worker(tmp_path):
    spec = load_spec(tiny_spec(tmp_path, garments=("camisole",), sizes=(12,), random=False,
                               render=False))  # fmt: skip
    pool = _pid_killing_pool(0)(1, threads=1, float64=True)
    summary = run_batch(spec, tmp_path / "o", pool=pool, progress=False)
    df = load(tmp_path / "o")
    assert summary.ran == 1 and df.status[0] in ("accepted", "rejected")
    assert df.attempts[0] == 2


@pytest.mark.slow
def test_a_two_node_cluster_on_this_machine(six, tmp_path):
    """ray.cluster_utils.Cluster: a head and a second node of one CPU each; the batch joins
    it by address and gives the same positions as the local run."""
    import ray
    from ray.cluster_utils import Cluster

    spec, out, _ = six
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    try:
        cluster.add_node(num_cpus=1)
        cluster.wait_for_nodes()
        sub = load_spec(tiny_spec(tmp_path, garments=("camisole",), sizes=(10, 14),
                                  random=False))  # fmt: skip
        summary = run_batch(sub, tmp_path / "c", address=cluster.address, progress=False)
        assert summary.workers == 2
        got = load(tmp_path / "c").set_index("task_id").positions_sha256
        ref = load(out).set_index("task_id").positions_sha256
        assert (got == ref[got.index]).all()
    finally:
        ray.shutdown()
        cluster.shutdown()
