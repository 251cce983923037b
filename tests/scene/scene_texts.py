"""Scene texts the loader's tests build on: a head (camera and sun), a capsule, many lights."""

from __future__ import annotations

import trimesh

from game.scene import Scene, parse_scene

HEAD = """\
name = "test"

[camera]
position = [0.0, 2.0, 10.0]
target = [0.0, 0.0, 0.0]

[light]
kind = "directional"
direction = [0.0, -2.0, 0.0]
"""

CAPSULE = 'shape = "capsule"\nradius = 0.3\nheight = 1.8\n'


def scene_with(body: str) -> Scene:
    """Parse HEAD plus ``body``."""
    return parse_scene(HEAD + body)


def only_static(body: str) -> trimesh.Trimesh:
    """The world mesh of the one [[static]] described by ``body``."""
    return scene_with("[[static]]\n" + body).statics[0].mesh


LIGHTS = """\
[[light]]
kind = "directional"
direction = [0.0, -2.0, 0.0]

[[light]]
kind = "spot"
position = [-8.0, 6.0, -8.0]
direction = [0.6, -1.0, 0.6]
cone = 90.0
range = 16.0
color = [1.0, 0.85, 0.6]
intensity = 1.5

[[light]]
kind = "point"
position = [0, 3, 0]
intensity = 0
"""


def with_lights(lights: str) -> str:
    """HEAD with its [light] table replaced by ``lights``."""
    return HEAD.split("[light]")[0] + lights
