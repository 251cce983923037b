#!/usr/bin/env bash
# Every picture of the docs, made again with the command line: the built-in scene's hard
# shadows, its map debug view and the soft shadows of its linear light (the README), and the
# walkaround window with its HUD, its panel and soft shadows (docs/window.md; the window runs on
# GLFW's null platform, so no display is needed). Run it from anywhere: `bash docs/pictures.sh`. It prints how many maps the debug view shows (from the
# capture's stats), so that the caption can say what the picture holds.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
images=docs/images

# The built-in scene at 960x540, three seconds in (the walkers spread over the square).
python -m game capture --size 960x540 --time 3 --out "$work/hard"
cp "$work/hard/frame_0000.png" "$images/default.png"

# The same view, each pixel coloured by the map it read.
python -m game capture --size 960x540 --time 3 --debug-view map --stats "$work/maps.json" \
    --out "$work/maps"
cp "$work/maps/frame_0000.png" "$images/default_maps.png"
python - "$work/maps.json" <<'PY'
import json, sys
frame = json.load(open(sys.argv[1]))["frames"][0]
keys = ("maps_total", "maps_rendered", "maps_cached")
print("default_maps.png:", ", ".join(f"{k} {frame[k]}" for k in keys),
      "|", ", ".join(f"{k} {v}" for k, v in frame.items() if k.startswith("character")))
PY

# The same view with the scene's linear light added to its lights (which keep their hard
# shadows), its soft shadows traced by the voxel-cache tracer with 32 samples per point, at
# 480x270 to stay quick on a CPU renderer.
python -m game trace --size 480x270 --samples 32 --time 3 --out "$work/soft"
cp "$work/soft/frame_0000.png" "$images/soft_default.png"

# The window: its HUD, the full panel (F1), and soft shadows, after the frames it takes to settle.
python -m game play --platform null --frames 120 --fps 30 --screenshot "$images/window.png"
python -m game play --platform null --frames 120 --fps 30 --panel \
    --screenshot "$images/window_panel.png"
python -m game play --soft --platform null --frames 60 --fps 30 \
    --screenshot "$images/soft_window.png"
echo "wrote $images/default.png, default_maps.png, soft_default.png, window.png," \
    "window_panel.png and soft_window.png"
