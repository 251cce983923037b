#!/usr/bin/env bash
# The window with soft shadows, measured and pictured (docs/window.md, "Soft shadows in the
# window"): on the built-in scene at 960x540, GLFW's null platform, no display needed.
# 1. Frames per second with and without soft shadows, two alternating runs each, the walkers
#    walking, the camera still and then turning by a degree a frame: CPU time of the process
#    with LP_NUM_THREADS=0 (llvmpipe rasterises in the calling thread, so other processes' load
#    does not count), and wall time (noisy on a shared machine).
# 2. Pictures: still after 0, 1 and 5 s of the window's time, walking after 1 and 5 s, each also
#    beside the analytic picture of the same view, with the RMSE between them
#    (docs/images/soft_window_*.png, the figures in docs/images/soft_window_shots.json).
# 3. Refining: a still view, characters paused, frame by frame, with its refining ending at 8
#    (none), 16, 32 (the default) and 64 points along the segment: the visibility's RMSE against
#    analytic after each frame, and each frame's milliseconds (docs/images/soft_window_refine.jsonl).
# Run it from anywhere: `bash docs/soft_window.sh [FRAMES]` (default 60 timed frames a run).
set -euo pipefail
cd "$(dirname "$0")/.."
export LP_NUM_THREADS=0
frames=${1:-60}
runs=docs/images/soft_window_fps.jsonl
: > "$runs"
for round in 1 2; do
    for turn in 0 1; do
        python -m game.bench.soft_window fps --frames "$frames" --turn "$turn" >> "$runs"
        python -m game.bench.soft_window fps --soft --frames "$frames" --turn "$turn" >> "$runs"
    done
done
cat "$runs"
python -m game.bench.soft_window shots --out docs/images > docs/images/soft_window_shots.json
cat docs/images/soft_window_shots.json
refine=docs/images/soft_window_refine.jsonl
: > "$refine"
for points in 8 16 32 64; do
    python -m game.bench.soft_window refine --points "$points" --frames 10 >> "$refine"
done
cat "$refine"
