"""The acceptance figures: clumped at its defaults against each baseline, per scene."""

from __future__ import annotations

import math

from game.bench.rows import row_number
from game.bench.runs import COMPARED_GROUPS


def is_default(row: dict) -> bool:
    """The row's parameters are the method's defaults."""
    return row["run"].split("|")[2] == "defaults"


def compare(rows: list[dict], scene: str, baseline: str) -> dict | None:
    """clumped (defaults) against a baseline's runs on one scene, at equal or lower error.

    The baseline run compared is the cheapest one whose error is at least clumped's (clumped is
    then at equal or lower error); where every baseline run is more accurate, the one closest
    to clumped's error is taken and ``clumped_error_lower`` is False.
    """
    ok = [r for r in rows if r["scene"] == scene and r.get("status") == "ok"
          and not math.isnan(row_number(r, "error"))]
    mine = [r for r in ok if r["method"] == "clumped" and is_default(r)]
    theirs = [r for r in ok if r["method"] == baseline]
    if not mine or not theirs:
        return None
    m = mine[0]
    e, t = row_number(m, "error"), row_number(m, "total_ms_median")
    t_min = row_number(m, "total_ms_min")
    worse = [r for r in theirs if row_number(r, "error") >= e]
    if worse:
        # Among the baseline runs no more accurate than clumped, the most accurate (then the
        # cheapest): the fairest match, not the cheapest coarse map.
        pick = min(worse, key=lambda r: (row_number(r, "error"), row_number(r, "total_ms_median")))
    else:
        pick = min(theirs, key=lambda r: row_number(r, "error") - e)
    return {"scene": scene, "baseline": pick["run"], "clumped_run": m["run"],
            "clumped_ms": t, "clumped_error": e,
            "baseline_ms": row_number(pick, "total_ms_median"),
            "baseline_error": row_number(pick, "error"),
            "speedup": row_number(pick, "total_ms_median") / t if t > 0 else float("nan"),
            # The same ratio from each run's least-disturbed frame (robust to other jobs' load).
            "clumped_ms_min": t_min, "baseline_ms_min": row_number(pick, "total_ms_min"),
            "speedup_min": row_number(pick, "total_ms_min") / t_min if t_min > 0 else float("nan"),
            "clumped_error_lower": bool(worse)}


def acceptance(rows: list[dict]) -> dict:
    """The acceptance figures (clumped against each baseline, per scene), from this run's rows."""
    out: dict = {}
    if rows:
        out["renderer"] = rows[-1].get("renderer")
        out["version"] = rows[-1].get("version")
        out["clock"] = rows[-1].get("clock")
    for scene in sorted({r["scene"] for r in rows if r["group"] in COMPARED_GROUPS}):
        for baseline in ("single", "csm", "static-dynamic"):
            c = compare(rows, scene, baseline)
            if c is not None:
                out.setdefault("comparisons", []).append(c)
            c = compare([r for r in rows if r["method"] != baseline or is_default(r)], scene,
                        baseline)
            if c is not None:  # against the baseline at its defaults (what engines ship)
                out.setdefault("default_comparisons", []).append(c)
        ok = [r for r in rows if r["scene"] == scene and r.get("status") == "ok"
              and not math.isnan(row_number(r, "error"))]
        mine = [r for r in ok if r["method"] == "clumped" and is_default(r)]
        if mine:
            # On the front against the baselines: no baseline run both faster and more accurate.
            t, e = row_number(mine[0], "total_ms_median"), row_number(mine[0], "error")
            beaten_by = [r["run"] for r in ok if r["method"] != "clumped"
                         and row_number(r, "total_ms_median") <= t and row_number(r, "error") <= e
                         and (row_number(r, "total_ms_median") < t or row_number(r, "error") < e)]
            out.setdefault("clumped_default_on_front", {})[scene] = not beaten_by
            if beaten_by:
                out.setdefault("clumped_default_beaten_by", {})[scene] = beaten_by
    return out


