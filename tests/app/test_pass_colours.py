"""Each pass the window names has a colour of its own, in the graph and the HUD's bar."""

from game.app.window.figures import WINDOW_PASSES, PassHistory
from game.render.passes import DRAWING_PASSES, TOTAL


def test_every_named_pass_has_its_own_colour():
    history = PassHistory()
    names = (*DRAWING_PASSES, TOTAL, *WINDOW_PASSES)
    colours = {(c.x, c.y, c.z, c.w) for c in (history.colour(name) for name in names)}
    assert len(colours) == len(names)
