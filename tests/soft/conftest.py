"""Fixtures of the tracer's tests."""

from __future__ import annotations

import pytest

from game.render.renderer import Renderer
from tests.soft.tracer_helpers import Points


@pytest.fixture
def points_tracer(ctx):
    made = []

    def make(text, **kwargs):
        made.append(Points(ctx, text, **kwargs))
        return made[-1]

    yield make
    for p in made:
        p.release()




@pytest.fixture
def renderer(ctx, tiny, request):
    """A renderer of tiny.toml with the full G-buffer, at the size the test module names
    (``SIZE``)."""
    made = Renderer(ctx, tiny, request.module.SIZE, gbuffer=True)
    yield made
    made.release()
