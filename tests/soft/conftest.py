"""Fixtures of the tracer's tests."""

from __future__ import annotations

import pytest

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


