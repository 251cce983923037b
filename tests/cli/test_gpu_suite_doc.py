"""docs/reference.md's description of ``bench --suite gpu`` says what game/bench/gpu_suite.py
runs: the scenes, frame sizes, window frames, soft size and samples of the full and the quick
plans, and the time budget, read from the doc's paragraph and checked against the plans."""

from __future__ import annotations

import re

from game.bench.gpu_suite import BUDGET_S, FULL, QUICK
from tests.helpers import ROOT

WORDS = {"one": 1, "two": 2, "three": 3}


def suite_paragraph() -> str:
    """The doc's text on the suite, whitespace folded, from its heading to the quick plan."""
    text = (ROOT / "docs" / "reference.md").read_text()
    start = text.index("**`bench --suite gpu [--quick] [--out DIR]`**")
    end = text.index("llvmpipe.", text.index("`--quick` runs the same parts small", start))
    return " ".join(text[start:end].split())


def size(text: str) -> tuple[int, int]:
    w, h = text.split("x")
    return int(w), int(h)


def samples(text: str) -> tuple[int, ...]:
    """``1, 2, 4, ..., 64`` (doubling through the ellipsis) or ``1, 8, 64`` as numbers."""
    items = [item.strip() for item in text.split(",")]
    if "..." not in items:
        return tuple(int(item) for item in items)
    first = [int(item) for item in items[:items.index("...")]]
    last = int(items[-1])
    out = list(first)
    while out[-1] < last:
        out.append(out[-1] * 2)
    return tuple(out)


def match(pattern: str, text: str) -> re.Match:
    found = re.search(pattern, text)
    assert found, f"the doc's suite paragraph no longer says {pattern!r}: {text}"
    return found


def test_the_full_plan_is_the_one_the_doc_describes():
    text = suite_paragraph()
    budget = match(r"starts no new work after (\d+) minutes", text)
    assert int(budget[1]) * 60 == BUDGET_S
    hard = match(r"`single` and `static-dynamic` at (\d+)². on the courtyard .*?\(`(\w+)`\).*?; "
                 r"(\d+)x(\d+), (\w+) error frames? each", text)
    assert (int(hard[1]),) == FULL.single_resolutions
    assert (hard[2],) == FULL.towns
    assert (int(hard[3]), int(hard[4])) == FULL.size
    assert WORDS[hard[5]] == FULL.error_frames
    window = match(r"`window`: .*? (\d+) frames at (\d+x\d+)", text)
    assert int(window[1]) == FULL.window_frames and size(window[2]) == FULL.window_size
    soft = match(r"`soft`: the soft-shadow sweep on the courtyard at (\d+x\d+), "
                 r"N = ([\d, .]+?\d), with Embree", text)
    assert size(soft[1]) == FULL.soft_size
    assert samples(soft[2]) == FULL.soft_samples


def test_the_quick_plan_is_the_one_the_doc_describes():
    text = suite_paragraph()
    quick = text[text.index("`--quick` runs the same parts small"):]
    hard = match(r"the courtyard and a .*?\(`(\w+)`, `single` and `static-dynamic` at (\d+)²\) "
                 r"at (\d+x\d+)", quick)
    assert (hard[1],) == QUICK.towns
    assert (int(hard[2]),) == QUICK.single_resolutions
    assert size(hard[3]) == QUICK.size
    window = match(r"(\d+) window frames at (\d+x\d+)", quick)
    assert int(window[1]) == QUICK.window_frames and size(window[2]) == QUICK.window_size
    soft = match(r"the soft sweep at (\d+x\d+) with N = ([\d, .]+?\d):", quick)
    assert size(soft[1]) == QUICK.soft_size
    assert samples(soft[2]) == QUICK.soft_samples


def test_the_samples_reader_expands_the_doubling():
    assert samples("1, 2, 4, ..., 64") == (1, 2, 4, 8, 16, 32, 64)
    assert samples("1, 8, 64") == (1, 8, 64)
