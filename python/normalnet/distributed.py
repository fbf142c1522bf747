"""Denoising a collection across a Ray cluster: one task per mesh.

::

    import ray, normalnet.distributed as nd
    ray.init()                      # or ray.init(address="auto") on a cluster
    rows = nd.denoise_files(paths, "out/", method="gnf", mu_g=0.3)

Each task reads one file, denoises it and writes the result atomically
(``normalnet.denoise_file``), so a worker holds one mesh at a time; at most
``max_in_flight`` tasks are queued at once, so the driver's memory stays
bounded for any number of files. A task whose worker dies is retried
(``retries``); a bad mesh is not retried but reported in its row. Finished
outputs are skipped, so an interrupted run resumes where it stopped. The
summary rows are returned and written to ``out_dir/summary.csv`` and
``summary.json``.
"""

from __future__ import annotations

import csv
import json
import os
from typing import Any, Dict, Iterable, List, Optional

from . import denoise_file

FIELDS = ["input", "output", "method", "status", "faces", "seconds", "error"]


def output_path(input: str, out_dir: str, suffix: Optional[str] = None, folder: bool = False) -> str:
    """Where ``input`` goes: ``out_dir/<stem><suffix>`` (suffix: the
    input's), or ``out_dir/<folder>-<stem><suffix>`` with ``folder`` (what
    :func:`denoise_files` uses when stems collide, like ``normalnet batch``)."""
    stem, ext = os.path.splitext(os.path.basename(input))
    if folder:
        stem = os.path.basename(os.path.dirname(os.path.abspath(input))) + "-" + stem
    return os.path.join(out_dir, stem + (suffix or ext))


def write_summary(rows: List[Dict[str, Any]], out_dir: str) -> None:
    """``summary.csv`` and ``summary.json`` in ``out_dir`` (atomically)."""
    for name, write in (("summary.csv", _write_csv), ("summary.json", _write_json)):
        path = os.path.join(out_dir, name)
        tmp = f"{path}.tmp-{os.getpid()}"
        with open(tmp, "w", newline="") as fh:
            write(fh, rows)
        os.replace(tmp, path)


def _write_csv(fh: Any, rows: List[Dict[str, Any]]) -> None:
    w = csv.DictWriter(fh, fieldnames=FIELDS)
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k) for k in FIELDS})


def _write_json(fh: Any, rows: List[Dict[str, Any]]) -> None:
    json.dump(rows, fh, indent=1)


def denoise_files(
    paths: Iterable[str],
    out_dir: str,
    method: str = "normalnet",
    suffix: Optional[str] = None,
    retries: int = 2,
    max_in_flight: Optional[int] = None,
    cpus_per_task: float = 1.0,
    skip_existing: bool = True,
    **params: Any,
) -> List[Dict[str, Any]]:
    """Denoises every file of ``paths`` into ``out_dir`` on the Ray cluster
    this process is connected to (``ray.init()`` first; a local one is
    started if none is), one task per mesh. Returns one summary row per
    input, in input order."""
    import ray

    if not ray.is_initialized():
        ray.init()
    os.makedirs(out_dir, exist_ok=True)
    paths = [os.fspath(p) for p in paths]
    stems = [os.path.splitext(os.path.basename(p))[0] for p in paths]
    outputs = [output_path(p, out_dir, suffix, stems.count(s) > 1) for p, s in zip(paths, stems)]
    if len(set(outputs)) != len(outputs):
        raise ValueError("two inputs would write the same output; rename one")
    if max_in_flight is None:
        max_in_flight = max(2, int(2 * ray.cluster_resources().get("CPU", 2) / cpus_per_task))

    # one rayon thread per reserved CPU, so that tasks running side by side
    # do not each start a pool the size of the machine
    threads = str(max(1, int(cpus_per_task)))

    @ray.remote(
        num_cpus=cpus_per_task,
        max_retries=retries,
        retry_exceptions=True,
        runtime_env={"env_vars": {"RAYON_NUM_THREADS": threads}},
    )
    def task(inp: str, out: str) -> Dict[str, Any]:
        return denoise_file(inp, out, method, skip_existing, **params)

    rows: List[Optional[Dict[str, Any]]] = [None] * len(paths)
    pending: Dict[Any, int] = {}
    next_index = 0
    while next_index < len(paths) or pending:
        while next_index < len(paths) and len(pending) < max_in_flight:
            inp = paths[next_index]
            pending[task.remote(inp, outputs[next_index])] = next_index
            next_index += 1
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            i = pending.pop(ref)
            try:
                rows[i] = ray.get(ref)
            except Exception as e:  # the task failed after its retries
                rows[i] = {"input": paths[i], "output": outputs[i],
                           "method": method, "status": "failed", "faces": None,
                           "seconds": 0.0, "error": f"task failed after {retries} retries: {e}"}
    result = [r for r in rows if r is not None]
    write_summary(result, out_dir)
    return result
