"""`normalnet.distributed` on a real local Ray cluster started here."""

import json
import os

import pytest

import normalnet

ray = pytest.importorskip("ray", reason="ray is not installed (pip install ray)")


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, ignore_reinit_error=True, log_to_driver=False)
    yield
    ray.shutdown()


def test_denoise_files_on_a_local_cluster(cluster, tmp_path, example):
    import normalnet.distributed as nd

    v, f, _, _ = example
    src = tmp_path / "in"
    src.mkdir()
    paths = []
    for i in range(3):
        p = src / f"m{i}.obj"
        normalnet.write_mesh(p, normalnet.noise(v, f, level=0.2, seed=10 + i), f)
        paths.append(str(p))
    broken = src / "broken.obj"
    broken.write_text("not a mesh\n")
    paths.append(str(broken))
    out = tmp_path / "out"
    rows = nd.denoise_files(paths, str(out), method="gnf", max_in_flight=2, normal_iterations=5)
    assert [r["status"] for r in rows] == ["done", "done", "done", "failed"]
    assert [os.path.basename(r["input"]) for r in rows] == ["m0.obj", "m1.obj", "m2.obj", "broken.obj"]
    # the same result as a local call
    mine = normalnet.denoise(*normalnet.read_mesh(paths[1]), "gnf", normal_iterations=5)
    theirs, _ = normalnet.read_mesh(out / "m1.obj")
    assert abs(mine - theirs).max() < 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary) == 4 and "broken.obj" in (out / "summary.csv").read_text()
    # resumable: finished outputs are skipped
    again = nd.denoise_files(paths, str(out), method="gnf", normal_iterations=5)
    assert [r["status"] for r in again] == ["skipped", "skipped", "skipped", "failed"]
