"""Benchmarks of the Python package (not tests: numbers to read, wall and CPU time).

    python crates/ragdoll-py/bench.py [--cli PATH_TO_ragdoll]

1. Reading a result into numpy: 17 joints, 301 frames (10 s at 30 fps), local and world.
2. A run from Python against the command-line tool doing the same work: the built-in
   humanoid, a 5 kg blast, 10 s on the rigid backend, the glTF and the report written.
"""

import argparse
import os
import resource
import shutil
import subprocess
import tempfile
import time

import ragdoll_sim as rd


def clock():
    return time.perf_counter(), time.process_time()


def transforms_read():
    w = rd.World("rigid")
    h = w.add(rd.humanoid())
    r = w.run(10.0, fps=30)
    for space in ("local", "world"):
        n = 1000
        (w0, c0) = clock()
        for _ in range(n):
            a = r.transforms(h, space=space)
        (w1, c1) = clock()
        print(f"transforms({space}) {a.shape}: {1e6 * (w1 - w0) / n:.0f} us wall, "
              f"{1e6 * (c1 - c0) / n:.0f} us CPU per call")


def python_run(out):
    (w0, c0) = clock()
    w = rd.World("rigid")
    h = w.add(rd.humanoid())
    w.add_blast(5.0, (2.0, 0.5, 1.0), air=True)  # where the CLI puts it
    r = w.run(10.0)
    r.save(os.path.join(out, "py.glb"), handle=h)
    r.save(os.path.join(out, "py.json"))
    (w1, c1) = clock()
    return w1 - w0, c1 - c0


def cli_run(cli, out):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    subprocess.run([cli, "blast", "--tnt", "5", "--at", "2,0.5,1", "--seconds", "10",
                    "-o", os.path.join(out, "cli.glb")], check=True, capture_output=True)
    w1 = time.perf_counter()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return w1 - w0, cpu


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", default=shutil.which("ragdoll"))
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    transforms_read()
    if not a.cli:
        print("no ragdoll binary: skipping the comparison with the command-line tool")
        return
    with tempfile.TemporaryDirectory() as out:
        py = [python_run(out) for _ in range(a.repeat)]
        cli = [cli_run(a.cli, out) for _ in range(a.repeat)]
    best = lambda runs, k: min(r[k] for r in runs)  # noqa: E731
    print(f"10 s blast, rigid, glTF + report: Python {best(py, 0):.3f} s wall / {best(py, 1):.3f} s CPU, "
          f"CLI {best(cli, 0):.3f} s wall / {best(cli, 1):.3f} s CPU (best of {a.repeat})")


if __name__ == "__main__":
    main()
