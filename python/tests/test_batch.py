"""Batch mode: `normalnet batch` interrupted and resumed, and the Python
per-file unit."""

import json
import os
import signal
import subprocess
import time

import normalnet


def make_collection(folder, example, count):
    v, f, _, _ = example
    folder.mkdir()
    for i in range(count):
        normalnet.write_mesh(folder / f"m{i}.obj", normalnet.noise(v, f, level=0.2, seed=i), f)
    (folder / "broken.obj").write_text("v 0 0 0\nf 1 2 3\n")
    return folder


def test_cli_batch_resumes_after_an_interruption(cli, tmp_path, example):
    src = make_collection(tmp_path / "in", example, 4)
    out = tmp_path / "out"
    cmd = [cli, "batch", str(src), "--out", str(out), "-m", "normalnet", "--iterations", "2", "-q"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.time() + 120
    while time.time() < deadline and not (out / "m0.obj").exists():
        time.sleep(0.05)
    assert (out / "m0.obj").exists(), "the first output never appeared"
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    assert proc.returncode != 0, "interrupted before the end"
    first_mtime = os.path.getmtime(out / "m0.obj")
    finished_before = sorted(p.name for p in out.glob("m*.obj"))
    assert len(finished_before) < 4
    # no partial file is left behind
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    # every input processed; the broken one makes the batch exit 1
    assert done.returncode == 1, done.stderr
    assert "1 of 5 inputs failed" in done.stderr, done.stderr
    rows = json.loads((out / "batch_summary.json").read_text())
    status = {os.path.basename(r["input"]): r["status"] for r in rows}
    for name in finished_before:
        assert status[name] == "skipped", (name, status)
    assert status["broken.obj"] == "failed"
    assert sorted(p.name for p in out.glob("m*.obj")) == [f"m{i}.obj" for i in range(4)]
    assert os.path.getmtime(out / "m0.obj") == first_mtime
    assert "broken.obj" in (out / "batch_summary.csv").read_text()


def test_denoise_file_rows(tmp_path, example):
    src = make_collection(tmp_path / "in", example, 1)
    out = tmp_path / "m0.ply"
    row = normalnet.denoise_file(src / "m0.obj", out, "gnf")
    assert row["status"] == "done" and row["faces"] == 1560 and out.exists()
    assert normalnet.denoise_file(src / "m0.obj", out, "gnf")["status"] == "skipped"
    bad = normalnet.denoise_file(src / "broken.obj", tmp_path / "b.obj", "gnf")
    assert bad["status"] == "failed" and "broken.obj" in bad["error"]
    assert not (tmp_path / "b.obj").exists()
