"""The accuracy sweep's 5% rule on runs of a few shadowed pixels: a run that misclassifies at
most TINY_RUN_PX pixels is not counted over MAX_ERROR_PCT, however small its shadows."""

from __future__ import annotations

from game.bench import accuracy_summary
from game.bench.accuracy_summary import MAX_ERROR_PCT, TINY_RUN_PX


def _row(seed, method, mis, either):
    return {"seed": str(seed), "method": method, "misclassified": str(mis),
            "shadowed": str(either), "shadowed_either": str(either),
            "error_pct": str(100 * mis / either), "notes": "", "status": "ok",
            "scene": f"scene {seed}"}


def test_a_few_wrong_pixels_of_a_few_shadowed_ones_are_not_over_the_limit():
    # A far camera over a sparse scene: 32 pixels shadowed, 5 misclassified, 15.6%.
    tiny = _row(84, "single", 5, 32)
    at_the_line = _row(85, "single", TINY_RUN_PX, 32)
    over = _row(86, "single", TINY_RUN_PX + 1, 32)
    assert all(float(r["error_pct"]) > MAX_ERROR_PCT for r in (tiny, at_the_line, over))
    s = accuracy_summary.summarise([tiny, at_the_line, over], ("single",))
    single = s["methods"][0]
    assert single["over_max_seeds"] == [86]
    assert single["over_max_without_note_seeds"] == [86]
    page = accuracy_summary.markdown(s, "")
    assert f"at most {TINY_RUN_PX} pixels is not counted over {MAX_ERROR_PCT:g}%" in page
    assert f"(more than {TINY_RUN_PX} px)" in page


def test_many_wrong_pixels_are_over_the_limit_whatever_the_shadows():
    big = _row(1, "clumped", 60, 1000)     # 6%
    under = _row(2, "clumped", 40, 1000)   # 4%
    s = accuracy_summary.summarise([big, under], ("clumped",))
    assert s["methods"][0]["over_max_seeds"] == [1]
