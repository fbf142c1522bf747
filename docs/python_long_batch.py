"""Issue 39, item 3, through Python: the long batch's inputs through
``normalnet.distributed.denoise_files`` on a local Ray cluster.

Make the inputs with the Rust test (2,000 small meshes in four formats,
every 50th broken in one of 20 ways the readers refuse), then run this::

    LONG_BATCH_INPUTS=/tmp/long-in cargo test --workspace --all-features \\
        --test long_batch -- --ignored
    .venv-ci/bin/python docs/python_long_batch.py /tmp/long-in /tmp/long-out

It checks what the issue asks (every good file written once, every broken
one ``failed`` in the summary with a reason naming it, no temporary file
left) and prints the peak resident memory of the driver and of the Ray
processes (workers, raylet, GCS) once 10 % of the good outputs exist and at
the end: VmHWM and VmRSS of ``/proc/PID/status``, read every 50 ms.
Exits 1 when a check fails. Figures: docs/robustness.md.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from typing import Dict, List, Tuple


def status_kib(pid: int) -> Tuple[int, int]:
    """(VmHWM, VmRSS) of a process in KiB; (0, 0) once it is gone."""
    hwm = rss = 0
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    hwm = int(line.split()[1])
                elif line.startswith("VmRSS:"):
                    rss = int(line.split()[1])
    except OSError:
        pass
    return hwm, rss


def ray_processes() -> Dict[int, str]:
    """Ray's processes on this machine by kind: worker (``ray::IDLE``,
    ``ray::task``), agent, raylet, gcs_server, other (monitors, dashboard)."""
    found = {}
    for name in os.listdir("/proc"):
        if not name.isdigit() or int(name) == os.getpid():
            continue
        try:
            with open(f"/proc/{name}/cmdline", "rb") as fh:
                cmd = fh.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        program = os.path.basename(cmd.split(" ")[0])
        if cmd.startswith("ray::"):
            found[int(name)] = "agent" if cmd.split(" ")[0].endswith("Agent") else "worker"
        elif program in ("raylet", "gcs_server"):
            found[int(name)] = program
        elif "default_worker.py" in cmd:
            found[int(name)] = "worker"
        elif "/ray/" in cmd:
            found[int(name)] = "other"
    return found


def snapshot() -> Dict[str, Tuple[int, int]]:
    """Per kind: (largest VmHWM of one process, sum of VmRSS), driver too."""
    kinds: Dict[str, Tuple[int, int]] = {"driver": status_kib(os.getpid())}
    for pid, kind in ray_processes().items():
        hwm, rss = status_kib(pid)
        old = kinds.get(kind, (0, 0))
        kinds[kind] = (max(old[0], hwm), old[1] + rss)
    return kinds


class Watch(threading.Thread):
    """Counts outputs and takes a memory snapshot at 10 % and at the end."""

    def __init__(self, out_dir: str, good: int) -> None:
        super().__init__(daemon=True)
        self.out_dir, self.good = out_dir, good
        self.at_10: Dict[str, Tuple[int, int]] = {}
        self.seconds_10 = 0.0
        self.last: Dict[str, Tuple[int, int]] = {}
        self.stop = threading.Event()
        self.start_time = time.perf_counter()

    def outputs(self) -> int:
        try:
            return sum(1 for n in os.listdir(self.out_dir) if not n.startswith("summary."))
        except OSError:
            return 0

    def run(self) -> None:
        while not self.stop.is_set():
            snap = snapshot()
            if snap.get("worker"):
                self.last = snap
            if not self.at_10 and self.outputs() * 10 >= self.good:
                self.at_10 = snap
                self.seconds_10 = time.perf_counter() - self.start_time
            time.sleep(0.05)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("inputs")
    ap.add_argument("out_dir")
    ap.add_argument("--method", default="gnf")
    ap.add_argument("--cpus", type=int, default=2)
    args = ap.parse_args()

    import ray

    import normalnet
    import normalnet.distributed as nd

    paths = sorted(
        os.path.join(args.inputs, n)
        for n in os.listdir(args.inputs)
        if os.path.splitext(n)[1] in normalnet.MESH_SUFFIXES
    )
    # the Rust test breaks every 50th file (m0049, m0099, ...)
    broken = {p for p in paths if int(os.path.basename(p)[1:5]) % 50 == 49}
    good = len(paths) - len(broken)
    ray.init(num_cpus=args.cpus, include_dashboard=False, log_to_driver=False)
    watch = Watch(args.out_dir, good)
    watch.start()
    started = time.perf_counter()
    rows = nd.denoise_files(paths, args.out_dir, method=args.method)
    seconds = time.perf_counter() - started
    time.sleep(0.1)
    watch.stop.set()
    watch.join()
    ray.shutdown()

    problems: List[str] = []
    by_status: Dict[str, int] = {}
    for path, row in zip(paths, rows):
        by_status[row["status"]] = by_status.get(row["status"], 0) + 1
        if path in broken:
            if row["status"] != "failed":
                problems.append(f"{path}: broken but {row['status']}")
            elif os.path.basename(path) not in (row["error"] or ""):
                problems.append(f"{path}: reason does not name the file: {row['error']!r}")
        elif row["status"] != "done" or not os.path.isfile(row["output"]):
            problems.append(f"{path}: {row['status']} {row['error']!r}")
    written = [n for n in os.listdir(args.out_dir) if not n.startswith("summary.")]
    if len(written) != good:
        problems.append(f"{len(written)} files in {args.out_dir}, expected {good}")
    leftovers = [n for n in written if n.endswith(".tmp") or ".normalnet-" in n]
    if leftovers:
        problems.append(f"temporary files left: {leftovers[:5]}")

    print(f"{len(paths)} files: " + ", ".join(f"{n} {s}" for s, n in sorted(by_status.items()))
          + f"; {seconds:.1f} s with {args.cpus} CPUs, method {args.method}")
    print(f"10 % of the good outputs after {watch.seconds_10:.1f} s")
    print("process   peak RSS of one at 10 %   at the end   (sum of current RSS at 10 % / end)")
    for kind in sorted(set(watch.at_10) | set(watch.last)):
        a = watch.at_10.get(kind, (0, 0))
        b = watch.last.get(kind, (0, 0))
        print(f"{kind:10}  {a[0]:>10,} KiB  {b[0]:>14,} KiB   ({a[1]:,} / {b[1]:,} KiB)")
    for row in rows[49::50][:3]:
        print(f"e.g. {os.path.basename(row['input'])}: {row['error']}")
    for p in problems:
        print("PROBLEM:", p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
