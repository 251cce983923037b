"""The panel's maps tab: the maps of the last frame, cached or re-rendered, and one map's square
of its layer drawn by the layer viewer (game/app/window/layer_view.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from imgui_bundle import imgui

from game.app.window.imgui_layout import font_ratio
from game.app.window.layer_view import LayerViewer

if TYPE_CHECKING:
    from game.render.renderer import Renderer

LABELS = ("map",)                  # the labels beside the controls
LAYER_VIEW_PIXELS = 200            # on-screen side of the layer viewer, at font scale 1
MAP_LIST_HEIGHT = 110              # pixels at font scale 1
RENDERED_COLOUR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)
CACHED_COLOUR = imgui.ImVec4(0.5, 0.95, 0.5, 1.0)


class MapsTab:
    """Draws the maps tab; owns the layer viewer (made the first time a map is shown, in the
    context current then) and releases it."""

    def __init__(self) -> None:
        self.viewer: LayerViewer | None = None
        self.map_index = 0

    def draw(self, renderer: Renderer) -> None:
        """The maps of the last frame, cached or re-rendered, and a viewer of one layer."""
        plan, array = renderer.last_plan, renderer.shadow_array
        if plan is None or array is None or not plan.maps:
            imgui.text("no shadow maps yet")
            return
        rendered = set(plan.render_static) | set(plan.render_dynamic)
        self.map_index = min(self.map_index, len(plan.maps) - 1)
        _, self.map_index = imgui.slider_int("map", self.map_index, 0, len(plan.maps) - 1)
        rec = plan.maps[self.map_index]
        state = "re-rendered" if self.map_index in rendered else "cached"
        imgui.text_wrapped(f"{rec.name}: layer {rec.layer}, {rec.viewport}^2 texels, "
                           f"{len(rec.objects)} object(s), {state}")
        if self.viewer is None:
            self.viewer = LayerViewer(renderer.ctx)
        self.viewer.draw(array, rec.layer, rec.viewport / array.resolution,
                         tuple(v / array.resolution for v in rec.origin))
        side = min(LAYER_VIEW_PIXELS * font_ratio(), imgui.get_content_region_avail().x)
        # GL textures start at the bottom row: flip v.
        imgui.image(imgui.ImTextureRef(self.viewer.texture.glo), imgui.ImVec2(side, side),
                    imgui.ImVec2(0, 1), imgui.ImVec2(1, 0))
        # Every map this frame: red re-rendered, green served from the cache.
        if imgui.begin_child("map list", imgui.ImVec2(0, MAP_LIST_HEIGHT * font_ratio()),
                             0, imgui.WindowFlags_.horizontal_scrollbar.value):
            for i, m in enumerate(plan.maps):
                fresh = i in rendered
                imgui.text_colored(RENDERED_COLOUR if fresh else CACHED_COLOUR,
                                   f"{i:3d} {m.name:<14} layer {m.layer:3d} "
                                   f"{'re-rendered' if fresh else 'cached'}")
        imgui.end_child()

    def release(self) -> None:
        if self.viewer is not None:
            self.viewer.release()
            self.viewer = None
