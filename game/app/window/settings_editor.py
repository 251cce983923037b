"""The overlay's editor of the hard-shadow settings: one control per :class:`ShadowSettings`
field, chosen by the field's name and its default's type, so settings added later appear
without edits here. The method list is the registry's."""

from __future__ import annotations

import dataclasses

from imgui_bundle import imgui

from game.shadows import clumping, registry
from game.shadows.plan import SHADOW_BUDGET_MIB, ShadowSettings

# The methods offered: the map-based ones and the compute tracer's exact hard shadows.
METHODS = tuple(registry.METHODS)
RESOLUTIONS = (128, 256, 512, 1024, 2048, 4096)  # larger layers: GiBs of depth array
# Settings read only by the shading pass: edited in place, no re-clumping, maps stay cached.
SHADING_ONLY = {"normal_bias", "depth_bias", "slope_bias", "max_slope", "pcf"}
SETTING_CHOICES = {"method": lambda: METHODS,
                   "clumping": lambda: clumping.STRATEGIES,
                   "grid": lambda: ("auto", "on", "off")}
MAX_INT_EDIT = 1 << 16           # drag limits of whole-number and real settings
MAX_FLOAT_EDIT = 1e6
# Settings whose valid range is narrower than those limits (the command line's bounds): a drag
# cannot leave them, so the planner never sees a value it refuses.
EDIT_RANGES = {"texels_per_metre": (0.01, 4096.0), "cascade_lambda": (0.0, 1.0),
               "max_slope": (0.0, 1000.0), "budget_mib": (1.0, 65536.0), "cascades": (1, 16),
               "clump_count": (1, 1024)}
# The value an "auto" setting takes when it is first set by hand.
MANUAL_START = {"budget_mib": float(SHADOW_BUDGET_MIB)}
# Words shortened in the labels, so that the labels leave the controls room in a narrow panel;
# a shortened label shows the field's name as its tooltip.
SHORT_WORDS = {"character": "char"}


def label_of(name: str) -> str:
    """The label of a settings field: its name in words, long words shortened."""
    return " ".join(SHORT_WORDS.get(word, word) for word in name.split("_"))


class SettingsEditor:
    """Draws the settings controls; a number being dragged is applied when the drag ends, so
    fields that need new maps do not re-plan them on every step."""

    def __init__(self) -> None:
        self._pending: dict[str, float] = {}   # drags in progress on re-planning fields

    @staticmethod
    def labels(settings: ShadowSettings) -> list[str]:
        """The labels beside the controls, in order."""
        return [label_of(field.name) for field in dataclasses.fields(settings)]

    def draw(self, settings: ShadowSettings, changes) -> None:
        """One control per settings field, chosen by the field's name and default's type."""
        new = {}
        for field in dataclasses.fields(settings):
            name, value = field.name, getattr(settings, field.name)
            label = label_of(name)
            if name in SETTING_CHOICES:
                items = list(SETTING_CHOICES[name]())
                if value not in items:
                    items.append(value)
                changed, index = imgui.combo(label, items.index(value), items)
                if changed:
                    new[name] = items[index]
            elif name.endswith("_resolution"):
                items = [str(r) for r in RESOLUTIONS]
                if str(value) not in items:
                    items.append(str(value))
                changed, index = imgui.combo(label, items.index(str(value)), items)
                if changed:
                    new[name] = int(items[index])
            elif isinstance(field.default, bool) or isinstance(value, bool):
                changed, flag = imgui.checkbox(label, value)
                if changed:
                    new[name] = flag
            elif value is None or isinstance(value, int):
                self._edit_number(label, name, value, field.default is None, new)
            elif isinstance(value, float):
                self._edit_number(label, name, value, field.default is None, new)
            else:
                imgui.text(f"{label}: {value}")
            if label != name.replace("_", " "):
                imgui.set_item_tooltip(name)
        shading = {k: v for k, v in new.items() if k in SHADING_ONLY}
        for key, value in shading.items():
            setattr(settings, key, value)  # read by the shading pass every frame
        planned = {k: v for k, v in new.items() if k not in SHADING_ONLY}
        if planned:
            changes.settings = dataclasses.replace(settings, **planned)

    def _edit_number(self, label: str, name: str, value, optional: bool, new: dict) -> None:
        """A drag for a number; fields that need new maps apply when the drag ends."""
        if optional:
            changed, auto = imgui.checkbox(f"auto##{name}", value is None)
            imgui.same_line()
            if changed:
                new[name] = None if auto else MANUAL_START.get(name, 1)
                return
            if auto:
                imgui.text(label)
                return
        shown = self._pending.get(name, value)
        if isinstance(value, int):
            lo, hi = EDIT_RANGES.get(name, (1, MAX_INT_EDIT))
            changed, number = imgui.drag_int(label, int(shown), 0.2, int(lo), int(hi))
        else:
            lo, hi = EDIT_RANGES.get(name, (0.0, MAX_FLOAT_EDIT))
            changed, number = imgui.drag_float(label, float(shown), 0.05, lo, hi, "%.2f")
            number = min(max(number, lo), hi)  # typed-in values are not clamped by imgui
        if changed and name in SHADING_ONLY:
            new[name] = number
        elif changed:
            self._pending[name] = number
        if imgui.is_item_deactivated() and name in self._pending:
            new[name] = self._pending.pop(name)
