"""Simulated data-cache misses of the CPU twin's kernels, under valgrind.

How the twin's own accesses are isolated: a child process (``python -m
game.bench.cache_grind WORKDIR``) runs under ``valgrind --tool=callgrind --cache-sim=yes
--instr-atstart=no``, whose cache simulator is cachegrind's (first-level and last-level data
caches, LRU, write-allocate). Nothing is simulated while Python, numpy and numba load; the
kernels are compiled first by the same child run natively, for a generic x86-64 CPU
(``NUMBA_CPU_NAME=generic``: valgrind's virtual CPU lacks AVX-512), into numba's cache, which the
run under valgrind loads. Around each kernel call a tiny C library, compiled here with gcc against
valgrind's ``callgrind.h``, issues callgrind's client requests: it starts the instrumentation,
evicts the simulated caches by writing a buffer three times the last level's size, zeroes the
counts, and after the call dumps them under the job's label and stops the instrumentation. So
each dump holds one kernel call, from caches that hold none of the scene (one frame's trace,
cold), and its small fixed overhead (the return from ctypes, numba's dispatch) is measured by a
call on no points and subtracted. The kernel runs on one thread.

The cache geometry is fixed, not the host's: a first level of 48 KiB, 12-way (this machine's
per-core L1d) and a last level of 2 MiB, 16-way (its per-core L2; its shared 480 MiB L3 would hold
any of these scenes whole and show only first-touch misses). Lines are 64 bytes.
"""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from game.app import outputs
from game.errors import GameError

I1 = (32768, 8, 64)
D1 = (49152, 12, 64)
LL = (2097152, 16, 64)
FLUSH_BYTES = 3 * LL[0]
HEADER = "/usr/include/valgrind/callgrind.h"
MARKER_C = r"""
#include <valgrind/callgrind.h>
void cg_begin(volatile char *buf, long n) {
    CALLGRIND_START_INSTRUMENTATION;
    for (long i = 0; i < n; i += 64) buf[i] += 1;
    CALLGRIND_ZERO_STATS;
}
void cg_end(const char *label) {
    CALLGRIND_DUMP_STATS_AT(label);
    CALLGRIND_STOP_INSTRUMENTATION;
}
"""
EVENTS = ("Dr", "Dw", "D1mr", "D1mw", "DLmr", "DLmw", "Ir")
BASELINE = "baseline"
TRIGGER = "desc: Trigger: Client Request: "


def missing_tools() -> str | None:
    """Why the simulation cannot run here, or None."""
    if shutil.which("valgrind") is None:
        return "valgrind is not installed (apt-get install valgrind)"
    if shutil.which("gcc") is None:
        return "gcc is not installed: it compiles the client-request marker for valgrind"
    if not Path(HEADER).is_file():
        return f"valgrind's {HEADER} is missing (apt-get install valgrind)"
    return None


def cache_config() -> dict:
    return {"tool": "valgrind --tool=callgrind --cache-sim=yes (cachegrind's simulator)",
            "I1": list(I1), "D1": list(D1), "LL": list(LL),
            "start": "cold: caches evicted before every kernel call"}


def _marker(workdir: Path) -> Path:
    lib = workdir / "libcgmark.so"
    src = workdir / "cgmark.c"
    outputs.write_bytes(src, MARKER_C.encode())
    done = subprocess.run(["gcc", "-O1", "-shared", "-fPIC", "-o", str(lib), str(src)],
                          capture_output=True, text=True)
    if done.returncode:
        raise GameError(f"gcc could not build the valgrind marker: "
                        f"{(done.stderr.strip().splitlines() or ['?'])[-1]}")
    return lib


def simulate(scene, points, jobs: list[tuple[str, int]], workdir: Path,
             timeout_s: float | None = None) -> dict[tuple[str, int], dict]:
    """Each (method, samples) job's simulated events (minus the fixed overhead) and the
    visible samples per point that the run under valgrind found."""
    reason = missing_tools()
    if reason:
        raise GameError(f"the cache suite needs valgrind: {reason}")
    workdir.mkdir(parents=True, exist_ok=True)
    for old in workdir.glob("cg.out*"):
        old.unlink()
    lib = _marker(workdir)
    outputs.write_npz(workdir / "job.npz", {
        **scene.arrays(), "positions": points.positions, "normals": points.normals,
        "index": points.index, "jobs": np.array(json.dumps([list(j) for j in jobs]))})
    root = str(Path(__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]),
           # Portable code for valgrind's CPU (no AVX-512), cached apart from the native build.
           "NUMBA_CPU_NAME": "generic", "NUMBA_NUM_THREADS": "1"}
    warm = subprocess.run([sys.executable, "-m", "game.bench.cache_grind", str(workdir), str(lib),
                           "--compile-only"], capture_output=True, text=True, env=env)
    if warm.returncode:
        lines = [x for x in warm.stderr.strip().splitlines() if x.strip()] or ["?"]
        raise GameError(f"the twin's kernels did not compile: {lines[-1]}")
    cmd = ["valgrind", "--tool=callgrind", "--cache-sim=yes", "--instr-atstart=no",
           "--smc-check=all-non-file", f"--I1={','.join(map(str, I1))}",
           f"--D1={','.join(map(str, D1))}", f"--LL={','.join(map(str, LL))}",
           f"--callgrind-out-file={workdir / 'cg.out'}", sys.executable, "-m",
           "game.bench.cache_grind", str(workdir), str(lib)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise GameError(f"the run under valgrind took over {timeout_s:.0f} s") from None
    if done.returncode:
        lines = [x for x in done.stderr.strip().splitlines() if x.strip()] or ["?"]
        raise GameError(f"the run under valgrind failed: {lines[-1]}")
    dumps = read_dumps(workdir)
    base = dumps.get(BASELINE)
    if base is None:
        raise GameError("valgrind wrote no baseline dump: the marker's client requests were lost")
    out = {}
    for i, (method, samples) in enumerate(jobs):
        events = dumps.get(f"job{i}")
        if events is None:
            raise GameError(f"valgrind wrote no dump for {method} N={samples}")
        out[(method, samples)] = {
            **{k: max(0, events[k] - base[k]) for k in EVENTS},
            "visible": np.load(workdir / f"visible{i}.npz")["visible"]}
    return out


def read_dumps(workdir: Path) -> dict[str, dict[str, int]]:
    """The events of every dump callgrind wrote, by its client-request label."""
    out = {}
    for path in sorted(workdir.glob("cg.out.*")):
        label, names, values = None, None, None
        for line in path.read_text(errors="replace").splitlines():
            if line.startswith(TRIGGER):
                label = line[len(TRIGGER):].strip()
            elif line.startswith("events:"):
                names = line.split()[1:]
            elif line.startswith("summary:"):
                values = [int(x) for x in line.split()[1:]]
        if label and names and values:
            events = dict(zip(names, values, strict=False))
            out[label] = {k: int(events.get(k, 0)) for k in EVENTS}
    return out


def _child(workdir: Path, lib_path: Path, compile_only: bool = False) -> None:
    """Under valgrind: load the job, then one marked call per job. With ``compile_only``
    (natively, first): compile the kernels into numba's cache, for valgrind to load."""
    from game.soft import cpu_twin

    z = np.load(workdir / "job.npz")
    scene = cpu_twin.TwinScene.from_arrays(z)
    points = cpu_twin.TwinPoints(z["positions"], z["normals"], z["index"])
    jobs = json.loads(str(z["jobs"]))
    k = cpu_twin.kernels()
    lib = ctypes.CDLL(str(lib_path))
    flush = np.zeros(FLUSH_BYTES, np.uint8)
    none = cpu_twin.TwinPoints(points.positions[:0], points.normals[:0], points.index[:0])
    k.trace_strided(0, 1, cpu_twin.CHUNK, *cpu_twin.kernel_args(scene, none, "grid", 1,
                                                               count=False))  # compiles
    if compile_only:
        return
    for label, (method, samples), pts in [(BASELINE, ("grid", 1), none)] + [
            (f"job{i}", job, points) for i, job in enumerate(jobs)]:
        args = cpu_twin.kernel_args(scene, pts, method, samples, count=False)
        lib.cg_begin(ctypes.c_void_p(flush.ctypes.data), ctypes.c_long(flush.nbytes))
        k.trace_strided(0, 1, cpu_twin.CHUNK, *args)
        lib.cg_end(label.encode())
        if label != BASELINE:
            outputs.write_npz(workdir / f"visible{label[3:]}.npz", {"visible": args[-5]})


if __name__ == "__main__":
    _child(Path(sys.argv[1]), Path(sys.argv[2]), "--compile-only" in sys.argv[3:])
