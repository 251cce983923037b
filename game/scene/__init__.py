"""The scene: its model, the TOML scene file, mesh files, shapes, procedural towns, and the
triangles packed for drawing.

Owns everything a scene is before any GL exists. May import only ``game.errors``,
``game.transforms`` and ``game.data``: every other layer builds on this one.
"""

from game.scene.loader import default_scene_path, load_scene, parse_scene, reference_scene_path
from game.scene.model import Body, Camera, Character, Light, LinearLight, Scene

__all__ = ["Body", "Camera", "Character", "Light", "LinearLight", "Scene", "default_scene_path",
           "load_scene", "parse_scene", "reference_scene_path"]
