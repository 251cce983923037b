#!/usr/bin/env bash
# The window with soft shadows, pictured (docs/window.md, "Soft shadows in the window"): on the
# built-in scene at 960x540, GLFW's null platform, no display needed. Its frame rates, with soft
# shadows and without, are the window suite's (python -m game bench --suite window), on the
# results page.
# 1. Pictures: still after 0, 1, 5 and 60 s of the window's time, walking after 1 and 5 s, each also
#    beside the analytic picture of the same view, with the RMSE between them
#    (docs/images/soft_window_*.png, the figures in docs/images/soft_window_shots.json).
# 2. Refining: a still view, characters paused, frame by frame, with its refining ending at 8
#    (none), 16, 32 (the default) and 64 points along the segment: the visibility's RMSE against
#    analytic after each frame, and each frame's milliseconds (docs/images/soft_window_refine.jsonl).
# 3. Settling: the same still view with the default 32 points, for 800 frames, as it settles
#    to the exact visibility: the RMSE every 50 frames, the share settled and each
#    frame's milliseconds (docs/images/soft_window_settle.json).
# Run it from anywhere: `bash docs/soft_window.sh`.
set -euo pipefail
cd "$(dirname "$0")/.."
export LP_NUM_THREADS=0
python -m game.bench.soft_window shots --out docs/images > docs/images/soft_window_shots.json
cat docs/images/soft_window_shots.json
refine=docs/images/soft_window_refine.jsonl
: > "$refine"
for points in 8 16 32 64; do
    python -m game.bench.soft_window refine --points "$points" --frames 10 >> "$refine"
done
cat "$refine"
python -m game.bench.soft_window refine --frames 800 --every 50 > docs/images/soft_window_settle.json
python -c "import json; d = json.load(open('docs/images/soft_window_settle.json')); print(d['rmse_visibility'], d['settled'][-1])"
