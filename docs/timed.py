#!/usr/bin/env python3
"""Helpers of docs/kernel_paths.sh that need no perf or GNU time.

  timed.py cores
      one logical CPU per physical core, comma-separated (SMT siblings left
      out, so lanes pinned to these do not share a core)
  timed.py run [--cpus LIST] [--timeout S] -- COMMAND...
      runs COMMAND (pinned to LIST when given, killed after S seconds) and
      prints one line `wall_s cpu_s peak_rss_mb rc` to stderr, last, for
      that child alone (os.wait4's rusage); its stdout is passed through
"""
import os
import subprocess
import sys
import time


def cores():
    seen, picked = set(), []
    for cpu in sorted(os.sched_getaffinity(0)):
        base = f"/sys/devices/system/cpu/cpu{cpu}/topology"
        try:
            key = (open(f"{base}/physical_package_id").read().strip(),
                   open(f"{base}/core_id").read().strip())
        except OSError:
            key = ("?", str(cpu))
        if key not in seen:
            seen.add(key)
            picked.append(cpu)
    print(",".join(map(str, picked)))


def run(args):
    cpus, timeout = None, None
    while args and args[0] != "--":
        flag, value, args = args[0], args[1], args[2:]
        if flag == "--cpus":
            cpus = {int(c) for c in value.split(",")}
        elif flag == "--timeout":
            timeout = float(value)
        else:
            sys.exit(f"timed.py run: unknown flag {flag}")
    command = args[1:]
    start = time.monotonic()
    child = subprocess.Popen(
        command,
        preexec_fn=(lambda: os.sched_setaffinity(0, cpus)) if cpus else None)
    deadline = start + timeout if timeout else None
    while True:
        pid, status, usage = os.wait4(child.pid, os.WNOHANG)
        if pid:
            break
        if deadline and time.monotonic() > deadline:
            child.kill()
        time.sleep(0.05)
    wall = time.monotonic() - start
    rc = os.waitstatus_to_exitcode(status)
    print(f"{wall:.2f} {usage.ru_utime + usage.ru_stime:.2f} "
          f"{usage.ru_maxrss / 1024:.0f} {rc}", file=sys.stderr)


if __name__ == "__main__":
    if sys.argv[1:2] == ["cores"]:
        cores()
    elif sys.argv[1:2] == ["run"]:
        run(sys.argv[2:])
    else:
        sys.exit(__doc__)
