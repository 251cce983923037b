#!/usr/bin/env bash
# The README's pictures, made again with the command line: the built-in scene's hard shadows,
# its map debug view, and the soft shadows of its linear light. Run it from
# anywhere: `bash docs/pictures.sh`. It prints how many maps the debug view shows (from the
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

# The same view lit by the scene's linear light, soft shadows traced by the voxel-cache tracer
# with 32 samples per point, at 480x270 to stay quick on a CPU renderer.
python -m game trace --size 480x270 --samples 32 --time 3 --out "$work/soft"
cp "$work/soft/frame_0000.png" "$images/soft_default.png"
echo "wrote $images/default.png, $images/default_maps.png and $images/soft_default.png"
