"""What capture and trace share: when their frames are, how a frame is written, and how a run
ends (its stats file, and Ctrl-C)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from game.app import dumps, frame_log, interrupts, outputs
from game.gpu import resources
from game.render.renderer import Frame, View
from game.scene import Scene


def resource_stats(frame: Frame) -> dict:
    """Live GL objects (by owner) and the process's resident memory: flat over long runs."""
    owners = frame.gl_objects or {}
    return {"gl_objects": sum(owners.values()), "gl_objects_by_owner": owners,
            "rss_mib": round(resources.rss_bytes() / 2**20, 2)}


@dataclass
class HeadlessRun:
    """What every headless run writes and when its frames are: frame k is at scene time
    ``time + k / fps``, written as ``out/frame_kkkk.*``."""

    out: Path
    frames: int = 1
    size: tuple[int, int] = (960, 540)
    time: float = 0.0
    fps: float = 30.0
    dump: bool = False
    stats: Path | None = None
    clock: str = "auto"

    def frame_time(self, k: int) -> float:
        return self.time + k / self.fps

    def frame_stem(self, k: int) -> Path:
        return self.out / f"frame_{k:04d}"

    def prepare(self) -> None:
        """Clear the temp files that killed runs left in the output folder (and beside the
        stats file). The folder itself is made with the first frame's files: a run that fails
        before it (a frame too large for the GL, maps too many) leaves no empty folder."""
        if self.out.is_dir():
            outputs.remove_stale_temps(self.out)
        if self.stats is not None:
            outputs.remove_stale_temps(self.stats.parent)

    def write_frame(self, k: int, t: float, frame: Frame, scene: Scene, view: View) -> None:
        """Frame k's PNG and, with ``dump``, its NPZ and GLB: all of them or none."""
        self.out.mkdir(parents=True, exist_ok=True)
        stem = self.frame_stem(k)
        with outputs.together():
            outputs.write_png(stem.with_suffix(".png"), frame.image)
            if self.dump:
                dumps.write_dump(stem, scene, view, self.size, t, frame)

    def run_frames(self, scene: Scene, view: View, render: Callable[[float], Frame],
                   entry: Callable[[int, float, Frame], dict]) -> tuple[frame_log.FrameLog, bool]:
        """Render and write every frame: ``render(t)`` makes the frame at scene time t,
        ``entry(k, t, frame)`` its stats entry. Ctrl-C ends the loop after the frame being
        written (its files and its entry are kept whole). Returns the entries, kept on disk so
        that a long run's memory stays flat, and whether Ctrl-C ended the loop."""
        frames = frame_log.FrameLog()
        with interrupts.caught() as interrupted:
            for k in range(self.frames):
                interrupts.check()
                t = self.frame_time(k)
                frame = render(t)
                with interrupts.deferred():
                    self.write_frame(k, t, frame, scene, view)
                    frames.append(entry(k, t, frame))
        return frames, interrupted.happened

    def finish(self, stats: dict, frames) -> None:
        """Write the stats file (``frames``: a FrameLog), then re-raise an interrupt the run
        stopped at (``stats["interrupted"]``)."""
        if self.stats is not None:
            frames.write_json(self.stats, stats)
        if stats.get("interrupted"):
            raise interrupts.Interrupted
