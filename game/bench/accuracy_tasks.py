"""One run of the accuracy sweep as a task that runs anywhere: one random scene, one map method
at its defaults, captured with dumps and scored against Embree.

A task draws its scene again from the scene's number (so a worker on another machine needs
nothing but this project and the real corpus), refuses it where it is not byte for byte the
scene the suite drew, and runs ``python -m game capture`` and ``python -m game verify`` as
processes of their own: every run gets its own EGL context and its own memory, and a crash is
one failed row. It returns its CSV row and the files to keep (the stats, the scores, the first
frame and its error pictures). :func:`run_task` is what the local workers and a Dask cluster
both call.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from game.app import outputs
from game.bench.runs import ERROR_SPACING_S
from game.errors import GameError
from game.scene import random_scene

# Past this a run is stopped and its row says so: the slowest scenes (the level at 960x540
# under four lights) take a few minutes on two cores.
TASK_TIMEOUT_S = 1800
KEPT = ("stats.json", "verify.json")   # besides frame 0's picture and its error pictures


class TaskFailed(Exception):
    """A run that could not be made or scored: its row's status says why."""


@dataclass(frozen=True)
class AccuracyTask:
    """One seed x method run; ``scene_sha256`` is the hash of the scene text the suite drew."""

    seed: int
    method: str
    size: tuple[int, int]
    frames: int
    scene_sha256: str

    @property
    def run_id(self) -> str:
        return f"{self.seed}|{self.method}|{self.size[0]}x{self.size[1]}|{self.frames}"


def scene_hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class _Children:
    """The processes the tasks of this process are running, so that a stopped sweep can end
    them rather than wait for them."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.live: set[subprocess.Popen] = set()
        self.stopping = False

    def run(self, args: list[str], timeout: float) -> tuple[int, str]:
        """Run ``args``; its status and standard error."""
        with self.lock:
            if self.stopping:
                raise TaskFailed("stopped")
            proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    text=True, env=_child_env())
            self.live.add(proc)
        try:
            _, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise TaskFailed(f"{args[3]} ran past {timeout:g} s") from None
        finally:
            with self.lock:
                self.live.discard(proc)
        return proc.returncode, err

    def stop(self) -> None:
        """End every running child (and start no more)."""
        with self.lock:
            self.stopping = True
            for proc in self.live:
                proc.terminate()


CHILDREN = _Children()


def _child_env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("SHADOWGAME_DEBUG", None)  # a child's failure is one line in the row
    return env


def _game(args: list[str]) -> None:
    """``python -m game ARGS`` in a process of its own; TaskFailed with its last line."""
    code, err = CHILDREN.run([sys.executable, "-m", "game", *args], TASK_TIMEOUT_S)
    if code != 0:
        lines = [line for line in err.splitlines() if line.strip()]
        last = lines[-1][:300] if lines else f"exit status {code}"
        raise TaskFailed(f"{args[0]}: {last}")


def run_task(task: AccuracyTask) -> dict:
    """Make and score one run; ``{"row": ..., "files": {name: bytes}}``. Never raises for a
    run that fails: its row's ``status`` says why."""
    start = time.perf_counter()
    row: dict = {"seed": task.seed, "method": task.method, "width": task.size[0],
                 "height": task.size[1], "frames": task.frames,
                 "scene_sha256": task.scene_sha256, "worker": socket.gethostname()}
    files: dict[str, bytes] = {}
    with tempfile.TemporaryDirectory(prefix="accuracy-") as tmp:
        try:
            row.update(_run(task, Path(tmp)))
            row["status"] = "ok"
        except (TaskFailed, GameError, OSError, ValueError, KeyError) as exc:
            row["status"] = f"failed: {type(exc).__name__}: {str(exc)[:300]}"
        files = _kept(Path(tmp) / "frames")
    row["seconds"] = round(time.perf_counter() - start, 2)
    return {"row": row, "files": files}


def _run(task: AccuracyTask, tmp: Path) -> dict:
    scene = random_scene.draw(task.seed)
    if scene_hash(scene.text) != task.scene_sha256:
        raise TaskFailed(f"this worker draws another scene for seed {task.seed} (another "
                         "version of the project?)")
    folder = tmp / "scene"
    folder.mkdir()
    for name, data in random_scene.scene_files(scene).items():
        outputs.write_bytes(folder / name, data)
    frames = tmp / "frames"
    frames.mkdir()
    w, h = task.size
    _game(["capture", str(folder / scene.file_name), "--method", task.method,
           "--size", f"{w}x{h}", "--frames", str(task.frames), "--fps", repr(1 / ERROR_SPACING_S),
           "--dump", "--stats", str(frames / "stats.json"), "--out", str(frames)])
    _game(["verify", str(frames), "--out", str(frames / "verify.json"), "--images"])
    stats = json.loads((frames / "stats.json").read_text(encoding="utf-8"))
    scores = json.loads((frames / "verify.json").read_text(encoding="utf-8"))
    return {"scene": scene.summary, **figures(stats, scores)}


def figures(stats: dict, scores: dict) -> dict:
    """A run's row figures from capture's stats and verify's scores: the counts pooled over
    the frames and the lights (as the bench pools them), the worst light's error, the frame
    times after the first (which compiles and draws every map) and capture's notes."""
    per_light: dict[int, list[int]] = {}
    total = {"misclassified": 0, "shadowed": 0, "shadowed_either": 0, "considered": 0}
    for frame in scores["frames"]:
        for light in frame["lights"]:
            mine = per_light.setdefault(int(light["light"]), [0, 0])
            mine[0] += int(light["misclassified"])
            mine[1] += int(light["shadowed_either"])
            for key in total:
                total[key] += int(light[key])
    times = [float(f["total"]) for f in stats["frames"]]
    later = times[1:] or times
    return {**total,
            "error_pct": round(100 * total["misclassified"] / max(1, total["shadowed_either"]),
                               4),
            "worst_light_error_pct": round(max(100 * m / max(1, e)
                                               for m, e in per_light.values()), 4),
            "light_misclassified": ";".join(str(per_light[k][0]) for k in sorted(per_light)),
            "lights": len(per_light), "characters": stats.get("characters", ""),
            "static_triangles": stats.get("static_triangles", ""),
            "ms": round(statistics.median(later), 3), "first_ms": round(times[0], 3),
            "notes": "; ".join(stats.get("notes", [])), "renderer": stats.get("renderer", "")}


def _kept(frames: Path) -> dict[str, bytes]:
    """The files a run returns: its stats and scores, frame 0 and frame 0's error pictures."""
    if not frames.is_dir():
        return {}
    names = [*KEPT, "frame_0000.png",
             *sorted(p.name for p in frames.glob("frame_0000*_errors.png"))]
    return {name: (frames / name).read_bytes() for name in names if (frames / name).is_file()}
