"""Run-time changes of the scene through the Python API: statics and characters added, removed,
moved.

Each change re-packs the geometry into the same GL buffers (no new GL objects) and tells the
shadow method what changed, so it re-renders only the maps the change makes stale.
"""

from __future__ import annotations

import numpy as np

from game.scene.model import Body, Character


class SceneEdits:
    """The edit methods of :class:`~game.render.renderer.Renderer`, which provides ``scene``,
    ``geom``, ``shadows`` (every light's method) and ``_geometry_changed``."""

    def add_static(self, body: Body) -> list[int]:
        """Add a static object; returns the clumps whose maps the next frame re-renders."""
        if body.name in self.scene.object_names():
            raise ValueError(f"an object named {body.name!r} exists already")
        self.scene.statics.append(body)
        return self._statics_changed({body.name})

    def remove_static(self, name: str) -> list[int]:
        """Remove a static object by name; its clump's map is re-rendered without it."""
        self.scene.statics.remove(self._static(name))
        return self._statics_changed({name})

    def move_static(self, name: str, transform: np.ndarray) -> list[int]:
        """Apply a world (4, 4) ``transform`` to a static: its old and new clumps re-render."""
        body = self._static(name)
        body.mesh = body.mesh.copy()
        body.mesh.apply_transform(np.asarray(transform, float))
        return self._statics_changed({name})

    def add_character(self, character: Character) -> None:
        """Add a character; it takes a free layer of the array if there is one."""
        if character.name in self.scene.object_names():
            raise ValueError(f"an object named {character.name!r} exists already")
        self.scene.characters.append(character)
        self._characters_changed()

    def remove_character(self, name: str) -> None:
        """Remove a character by name; its layer goes back to the pool."""
        matches = [c for c in self.scene.characters if c.name == name]
        if not matches:
            raise KeyError(f"no character named {name!r}")
        self.scene.characters.remove(matches[0])
        self._characters_changed()

    def _static(self, name: str) -> Body:
        for body in self.scene.statics:
            if body.name == name:
                return body
        raise KeyError(f"no static named {name!r}")

    def _statics_changed(self, names: set[str]) -> list[int]:
        """Every light's method re-plans; returns the first light's re-rendered clumps."""
        self._geometry_changed()
        changed = [m.update_statics(self.geom, names) for m in self.shadows.methods]
        return changed[0]

    def _characters_changed(self) -> None:
        self._geometry_changed()
        for method in self.shadows.methods:
            method.update_characters(self.geom)
