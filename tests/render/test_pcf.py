"""The shading pass's 3 x 3 PCF (``lookup`` in shaders/shadow.glsl) against numpy: the mean of
the nine depth compares around the sample's texel, each texel index held inside the map's own
square, for maps that fill a layer and maps in a square of an atlas layer, at their edges too.
"""

from __future__ import annotations

import numpy as np
import pytest

from game.gpu import blocks, glsl
from game.gpu.depth_array import DepthArray
from game.render.frame_blocks import shader_defines
from game.render.map_records import MapRecords
from game.shadows.plan import KIND_CLUMP

SIDE = 16        # texels per side of the array's layers
UNIT = 5         # the texture unit the probe reads the array from
PROBES = 4096

PROBE_SHADER = """
#version 430
layout(local_size_x = 64) in;
#include "world.glsl"
#include "lighting.glsl"
#include "shadow.glsl"
layout(std430, binding = 7) buffer Probes { vec4 probes[]; };  // map, u, v, depth -> result
void main() {
    uint k = gl_GlobalInvocationID.x;
    vec4 p = probes[k];
    probes[k] = vec4(lookup(map_ref(int(p.x)), p.yz, p.w));
}
"""


def _reference(depths: np.ndarray, layer: int, offset: np.ndarray, scale: float,
               uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """The mean of the nine compares (lit where depth <= the texel's) around the texel of each
    ``uv`` (the layer's), each index held inside the map's square."""
    first = np.floor(offset * SIDE + 0.5)
    last = first + np.floor(scale * SIDE + 0.5) - 1
    t = np.clip(np.floor(uv * SIDE), first, last).astype(int)
    total = np.zeros(len(uv))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            x = np.clip(t[:, 0] + dx, first[0], last[0]).astype(int)
            y = np.clip(t[:, 1] + dy, first[1], last[1]).astype(int)
            total += depth <= depths[layer, y, x]
    return total / 9.0


@pytest.fixture
def probe(ctx):
    """Runs ``lookup`` with PCF at probes (map, u, v, depth) over a 2-layer array of random
    depths and two maps: one filling layer 1, one in a quarter of layer 0."""
    from OpenGL import GL  # after the context: PyOpenGL picks its platform on import

    rng = np.random.default_rng(7)
    depths = rng.random((2, SIDE, SIDE)).astype(np.float32)
    array = DepthArray(ctx, SIDE, 2)
    maps = np.zeros(blocks.max_maps(ctx), blocks.MAP_DTYPE)
    maps[0]["layer"], maps[0]["uv_scale"] = 1, 1.0
    maps[1]["layer"], maps[1]["uv_scale"], maps[1]["uv_offset"] = 0, 0.5, (0.5, 0.25)
    maps["kind"] = KIND_CLUMP
    defines = {**shader_defines(ctx), "PCF": 1, "COUNT_PIXELS": 0, "COUNT_CANDIDATES": 0,
               "DEPTH_BOUNDS": 0, "LIGHT_KIND": blocks.LIGHT_KINDS["directional"],
               "GRID": blocks.GRID_NONE}
    held = []
    try:
        program = ctx.compute_shader(glsl.preprocess(PROBE_SHADER, defines, name="pcf probe"))
        held.append(program)
        records = MapRecords(ctx, len(maps))
        held.append(records)
        records.write(maps)
        records.bind(blocks.TEXTURE_UNITS["map_records"])
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, array.texture)
        GL.glTexSubImage3D(GL.GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, SIDE, SIDE, 2,
                           GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT, depths.tobytes())
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, 0)
        array.bind(UNIT)
        # moderngl 5.13 sets a compute shader's shadow sampler wrongly: set it through GL.
        GL.glProgramUniform1i(program.glo, GL.glGetUniformLocation(program.glo, "u_shadow_maps"),
                              UNIT)
        GL.glProgramUniform1i(program.glo, GL.glGetUniformLocation(program.glo, "u_map_records"),
                              blocks.TEXTURE_UNITS["map_records"])

        def run(points: np.ndarray) -> np.ndarray:
            buffer = ctx.buffer(points.astype(np.float32).tobytes())
            held.append(buffer)
            buffer.bind_to_storage_buffer(7)
            program.run(len(points) // 64)
            ctx.memory_barrier()
            return np.frombuffer(buffer.read(), np.float32).reshape(-1, 4)[:, 0]

        yield depths, maps, run
    finally:
        for obj in held:
            obj.release()
        array.release()


@pytest.mark.parametrize("index", [0, 1])
def test_pcf_is_the_mean_of_the_nine_compares_held_inside_the_square(probe, index):
    depths, maps, run = probe
    rng = np.random.default_rng(index)
    offset = np.asarray(maps[index]["uv_offset"], float)
    scale = float(maps[index]["uv_scale"])
    # Over the map (lookup's uv is the map's own, in [0, 1)), its first and last texels
    # included, with depths drawn from the texels' own range.
    inside = rng.uniform(0.0, 1.0, (PROBES, 2))
    inside[:64] = rng.uniform(0.0, 1.0 / (scale * SIDE), (64, 2))
    inside[64:128] = 1.0 - rng.uniform(1e-4, 1.0 / (scale * SIDE), (64, 2))
    # Exactly on texel edges (k / n, exact in float32 here) and on the far edge, 1.0.
    edges = np.arange(int(scale * SIDE) + 1) / (scale * SIDE)
    inside[128:128 + len(edges) ** 2] = np.stack(np.meshgrid(edges, edges), -1).reshape(-1, 2)
    depth = rng.random(PROBES)
    points = np.column_stack([np.full(PROBES, index), inside, depth])
    got = run(points)
    want = _reference(depths, int(maps[index]["layer"]), offset, scale,
                      offset + scale * inside, depth)
    assert np.allclose(got, want, atol=1e-6), \
        f"{np.sum(~np.isclose(got, want, atol=1e-6))} of {PROBES} probes differ"
    # Every ninth occurs: the probes reach partly shadowed texels, not only lit or dark ones.
    assert len(np.unique(np.round(got * 9))) == 10
