"""The names of a frame's timed passes: the keys of ``Frame.ms``, in the order a frame draws them.

Whatever lists or reads the passes (the window's overlay and summary, capture's summary, the
benchmark's columns) takes the names from here, so that a pass renamed or added is renamed or
added everywhere at once.
"""

from __future__ import annotations

# The camera's frame: maps, then shading (cull only where the renderer culls).
SHADOW_STATIC = "shadow_static"     # the static casters' maps that are not cached
SHADOW_DYNAMIC = "shadow_dynamic"   # the characters' maps
CULL = "cull"                       # the triangles that can show
SHADE = "shade"                     # every object seen from the camera, lit through the maps
# Lit by the compute tracer: the traced method (prefix "traced") or soft shadows ("soft").
TRACED_BUILD = "traced_build"
TRACED_TRACE = "traced_trace"
SOFT_BUILD = "soft_build"
SOFT_TRACE = "soft_trace"
SOFT_UPSAMPLE = "soft_upsample"     # the reduced soft trace filled in to full resolution
COMPOSITE = "composite"             # the frame lit again through the traced visibility
# Wall-clock time from planning to the end of the last pass.
TOTAL = "total"
READBACK = "readback"               # the frame read back to the CPU, after drawing it
GBUFFER = "gbuffer"                 # a soft-shadowed frame's total before its trace

# The camera's passes, in draw order.
PASSES = (SHADOW_STATIC, SHADOW_DYNAMIC, CULL, SHADE)
TRACED_PASSES = (TRACED_BUILD, TRACED_TRACE, SOFT_BUILD, SOFT_TRACE, SOFT_UPSAMPLE, COMPOSITE)
# Every pass that draws part of a frame, in draw order.
DRAWING_PASSES = PASSES + TRACED_PASSES
# What a summary or a table reports of every frame: the camera's passes and the whole.
PASSES_AND_TOTAL = (*PASSES, TOTAL)
