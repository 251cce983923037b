"""The bench charts, drawn from synthetic rows: labelled ticks on both axes, titles, units, and no
chart drawn from a single x value."""

import pytest

from game.bench import charts

pytest.importorskip("matplotlib", reason="bench charts need matplotlib (pip install .[bench])")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHODS = ("clumped", "single", "static-dynamic", "csm")


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def row(scene: str, method: str, params: str = "defaults", group: str = "main",
        status: str = "ok", **numbers) -> dict:
    """A row as read back from bench.csv: every cell a string."""
    r = {"run": f"{scene}|{method}|{params}|320x180", "scene": scene, "group": group,
         "factor": "", "value": "", "method": method, "status": status, "width": "320",
         "height": "180", "renderer": "llvmpipe", "clock": "cpu-finish"}
    r.update({k: f"{v:g}" for k, v in numbers.items()})
    return r


def town(scene: str, triangles: int, characters: int, ms: float) -> list[dict]:
    return [row(scene, m, group="town", static_triangles=triangles, characters=characters,
                total_ms_median=ms * (1 + i / 4), error=0.01 * (i + 1), maps_per_fragment=1 + i,
                flicker=0.001 * i) for i, m in enumerate(METHODS)]


def stability(factor: str, values: list[float]) -> list[dict]:
    rows = []
    for v in values:
        for i, m in enumerate(METHODS):
            r = row(f"stab_{factor}_{v:g}", m, group="stability", error=0.002 * i + v / 1e4,
                    total_ms_median=5.0)
            r.update(factor=factor, value=f"{v:g}")
            rows.append(r)
    return rows


def courtyard(ms: list[float]) -> list[dict]:
    """Runs on the courtyard costing ``ms`` (20 to 35 ms: less than a decade)."""
    out = [row("courtyard", m, total_ms_median=x, error=0.004 * (i + 1), maps_per_fragment=2,
               flicker=0.002) for i, (m, x) in enumerate(zip(METHODS, ms, strict=False))]
    out += [row("courtyard", "single", f"single_resolution={r}", total_ms_median=x,
                error=0.05 / (k + 1)) for k, (r, x) in enumerate(zip((1024, 8192), ms[4:],
                                                                      strict=False))]
    return out


def labelled(ax, axis: str) -> list[str]:
    """The non-empty tick labels, major and minor, inside the axis's view once drawn."""
    ax.figure.canvas.draw()
    lo, hi = sorted(ax.get_xlim() if axis == "x" else ax.get_ylim())
    labels = ax.get_xticklabels(which="both") if axis == "x" else ax.get_yticklabels(which="both")
    i = 0 if axis == "x" else 1
    return [t.get_text() for t in labels
            if t.get_text().strip() and lo <= t.get_position()[i] <= hi]


@pytest.mark.parametrize("ms", [[22.0, 25.0, 28.0, 35.0, 20.0, 31.0],  # 20 to 35 ms
                                [8.0, 11.0, 14.0, 18.0, 7.0, 16.0],   # across 10 ms
                                [60.0, 70.0, 90.0, 110.0, 140.0, 150.0]])
def test_pareto_spanning_less_than_a_decade_labels_two_plain_ticks(ms):
    ax = charts.pareto_figure(plt, courtyard(ms), "courtyard").axes[0]
    xs = labelled(ax, "x")
    assert len(xs) >= 2, xs
    assert all("$" not in t and "^" not in t for t in xs), xs  # 20, not 2x10^1
    assert len(labelled(ax, "y")) >= 2


def test_the_pareto_title_names_scene_size_and_points_and_the_axes_their_units():
    ax = charts.pareto_figure(plt, courtyard([8.0, 11.0, 14.0, 18.0]), "courtyard").axes[0]
    title = ax.get_title()
    assert "courtyard" in title and "320x180" in title and "one point per" in title, title
    assert "ms" in ax.get_xlabel() and "%" in ax.get_ylabel()


def test_the_pareto_legend_names_only_the_methods_the_run_measured():
    rows = [r for r in courtyard([8.0, 11.0, 14.0, 18.0]) if r["method"] in ("clumped", "single")]
    ax = charts.pareto_figure(plt, rows, "courtyard").axes[0]
    names = {t.get_text() for t in ax.get_legend().get_texts()}
    assert names == {"clumped", "single", "Pareto front"}, names


def test_a_scaling_chart_with_one_x_value_is_not_written(tmp_path):
    rows = courtyard([8.0, 12.0, 16.0, 19.0]) + town("town_2x2", 60_000, 16, 20.0)
    notes = []
    written = charts.write_all(rows, tmp_path, log=notes.append)
    names = {p.name for p in tmp_path.iterdir()}
    assert "pareto_courtyard.png" in names and "pareto_town_2x2.png" in names
    assert not any(n.startswith("scaling_triangles") for n in names)
    assert not any(p.name.startswith("scaling_") for p in written)
    assert set(written) == set(tmp_path.iterdir())
    assert any("scaling_triangles" in n and "one x value" in n for n in notes), notes
    _, skipped = charts.figures(rows)
    assert "one x value" in skipped["scaling_triangles"]


def test_a_scaling_chart_with_two_sizes_draws_a_line_per_method(tmp_path):
    rows = town("town_2x2", 60_000, 16, 20.0) + town("town_4x4", 250_000, 16, 28.0)
    fig = charts.scaling_figure(plt, rows, "triangles")
    ax = fig.axes[0]
    assert sorted(len(line.get_xdata()) for line in ax.get_lines()) == [2] * len(METHODS)
    assert len(labelled(ax, "x")) >= 2 and len(labelled(ax, "y")) >= 2
    assert "ms" in ax.get_ylabel() and "triangles" in ax.get_xlabel()
    written = charts.write_all(rows, tmp_path)
    assert tmp_path / "scaling_triangles.png" in written


def test_every_chart_has_a_title_units_and_two_labelled_ticks_per_axis():
    rows = (courtyard([22.0, 25.0, 28.0, 35.0, 20.0, 31.0])
            + town("town_2x2", 60_000, 16, 20.0) + town("town_4x4", 250_000, 16, 28.0)
            + town("town_4x4_c4", 250_000, 4, 24.0) + town("town_4x4_c64", 250_000, 64, 40.0)
            + stability("elevation", [2.0, 30.0, 90.0]) + stability("scale", [0.01, 1000.0])
            + stability("thin", [0.01]))
    built, skipped = charts.figures(rows)
    stems = {stem for stem, _ in built}
    assert stems == {"pareto_courtyard", "pareto_town_2x2", "pareto_town_4x4", "pareto_town_4x4_c4",
                     "pareto_town_4x4_c64", "scaling_triangles", "scaling_characters",
                     "maps_per_fragment", "flicker", "stability_elevation", "stability_scale",
                     "stability_thin"}
    assert not skipped
    for stem, fig in built:
        ax = fig.axes[0]
        assert ax.get_title().strip() and ax.get_xlabel().strip() and ax.get_ylabel().strip(), stem
        assert len(labelled(ax, "x")) >= 2, (stem, labelled(ax, "x"))
        assert len(labelled(ax, "y")) >= 2, (stem, labelled(ax, "y"))
        cost = ax.get_xlabel() if stem.startswith("pareto") else ax.get_ylabel()
        if stem.startswith(("pareto", "scaling")):
            assert "ms" in cost, stem
        if stem.startswith(("pareto", "stability")):
            assert "%" in ax.get_ylabel(), stem


def test_a_stability_factor_with_one_value_is_one_bar_per_method(tmp_path):
    rows = stability("thin", [0.01])
    rows[1]["status"] = "failed: RuntimeError: no maps"
    fig = charts.stability_figure(plt, rows, "thin")
    ax = fig.axes[0]
    assert labelled(ax, "x") == list(METHODS)
    assert "0.01 metres" in ax.get_title()
    assert "failed" in [t.get_text() for t in ax.texts]
    assert tmp_path / "stability_thin.png" in charts.write_all(rows, tmp_path)


def test_the_shadow_cost_chart_draws_each_method_against_walkers_and_a_proportional_line():
    rows = []
    for n, scene in ((4, "town_4x4_c4"), (16, "town_4x4"), (64, "town_4x4_c64"),
                     (256, "town_4x4_c256")):
        for i, m in enumerate(METHODS):
            rows.append(row(scene, m, group="town", characters=n, total_ms_median=30.0,
                            shadow_static_ms_median=0.01, shadow_dynamic_ms_median=5.0 + i + n / 8))
        rows.append(row(scene, "clumped", "character_texels_per_pixel=0.0", group="town",
                        characters=n, total_ms_median=40.0, shadow_static_ms_median=0.01,
                        shadow_dynamic_ms_median=n / 2))
    rows.append(row("town_8x8_c64", "clumped", group="town", characters=64, total_ms_median=9.0,
                    shadow_static_ms_median=0.0, shadow_dynamic_ms_median=1.0))  # another town
    fig = charts.scaling_figure(plt, rows, "shadow")
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert set(lines) == {*METHODS, "clumped char maps all at most",
                          "proportional to walkers (from clumped's first point)"}
    assert list(lines["clumped"].get_xdata()) == [4, 16, 64, 256]
    guide = lines["proportional to walkers (from clumped's first point)"]
    assert guide.get_ydata()[-1] == pytest.approx((5.01 + 4 / 8) * 64)
    assert "ms" in ax.get_ylabel() and "walkers" in ax.get_xlabel()
    assert len(labelled(ax, "x")) >= 2 and len(labelled(ax, "y")) >= 2
