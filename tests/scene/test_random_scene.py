"""Seeded random scenes (game/scene/random_scene.py): a seed always gives the same bytes, every
scene loads from its own folder wherever that folder is, and the draws vary what real scenes
vary."""

from __future__ import annotations

import math
import shutil
import tomllib

import pytest

from game.errors import GameError
from game.scene import load_scene, random_scene
from tests.cli.cli_helpers import run_main

CI_SEEDS = tuple(range(12))     # the fixed set CI draws, writes and loads
VARIETY_SEEDS = tuple(range(60))  # drawn as text only, to see what the draws cover

needs_corpus = pytest.mark.skipif(
    not all((random_scene.REAL_DIR / f).is_file()
            for f in (*random_scene.PROPS, random_scene.LEVEL_SCENE)),
    reason="random scenes use the real corpus: python assets/fetch_real.py fetches it")


@pytest.fixture(scope="module")
def variety():
    """The parsed text of every VARIETY_SEEDS scene, by seed."""
    return {seed: (random_scene.draw(seed), tomllib.loads(random_scene.draw(seed).text))
            for seed in VARIETY_SEEDS}


def _write(folder, files):
    folder.mkdir(parents=True)
    for name, data in files.items():
        (folder / name).write_bytes(data)


@needs_corpus
@pytest.mark.parametrize("seed", CI_SEEDS)
def test_a_seed_gives_the_same_bytes_and_loads_from_its_folder_anywhere(tmp_path, seed):
    first, again = random_scene.draw(seed), random_scene.draw(seed)
    files = random_scene.scene_files(first)
    assert files == random_scene.scene_files(again)
    assert first.size in random_scene.SIZES
    _write(tmp_path / "written", files)
    # Moved elsewhere, the folder still loads: it reads nothing outside itself.
    moved = tmp_path / "elsewhere" / "scene"
    shutil.copytree(tmp_path / "written", moved)
    shutil.rmtree(tmp_path / "written")
    scene = load_scene(moved / first.file_name)
    data = tomllib.loads(first.text)
    assert scene.name == first.name
    assert len(scene.statics) == len(data.get("static", []))
    assert len(scene.characters) == len(data.get("character", []))
    assert len(scene.lights) == len(data["light"])
    named = {t["file"] for kind in ("floor", "static", "character") for t in data.get(kind, [])
             if t["shape"] == "mesh"}
    assert named == set(first.meshes) and named <= set(files)


@needs_corpus
def test_different_seeds_give_different_scenes(variety):
    texts = {scene.text for scene, _ in variety.values()}
    assert len(texts) == len(variety)


@needs_corpus
def test_the_draws_cover_crowds_shapes_props_levels_lights_cameras_and_sizes(variety):
    shapes, lights, cameras, sizes, notes = set(), set(), set(), set(), set()
    walkers = []
    mesh_walkers = 0
    for scene, data in variety.values():
        shapes |= {t["shape"] for t in data.get("static", [])}
        lights |= {t["kind"] for t in data["light"]}
        cameras.add(data["camera"]["position"][1] > 10.0)
        sizes.add(scene.size)
        notes |= {n for n in ("a large tilted box", "a stack", "two boxes touching",
                              "the level") if f"# {n}" in scene.text}
        crowd = data.get("character", [])
        walkers.append(len(crowd))
        mesh_walkers += sum(t["shape"] == "mesh" for t in crowd)
    assert shapes == {"box", "sphere", "cylinder", "capsule", "cone", "mesh"}
    assert lights == {"directional", "spot", "point"}
    assert cameras == {True, False}, "street-level and high cameras"
    assert sizes == set(random_scene.SIZES)
    assert notes == {"a large tilted box", "a stack", "two boxes touching", "the level"}
    assert min(walkers) == 0 and max(walkers) > 100 and mesh_walkers > 0
    assert max(walkers) <= random_scene.MAX_WALKERS
    assert any(len(data["light"]) > 1 for _, data in variety.values())


@needs_corpus
def test_suns_stand_between_the_lowest_and_highest_elevation(variety):
    low, high = random_scene.SUN_ELEVATION
    elevations = [math.degrees(math.asin(-t["direction"][1]
                                         / math.dist(t["direction"], (0, 0, 0))))
                  for _, data in variety.values() for t in data["light"]
                  if t["kind"] == "directional"]
    assert elevations
    tolerance = 0.1  # degrees: the file's three decimals
    assert all(low - tolerance <= e <= high + tolerance for e in elevations), elevations


def test_a_missing_corpus_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setattr(random_scene, "REAL_DIR", tmp_path)
    with pytest.raises(GameError, match="fetch_real.py"):
        random_scene.draw(0)


@needs_corpus
def test_the_command_writes_the_folder_and_the_same_bytes_again(tmp_path, capsys):
    for out in (tmp_path / "a", tmp_path / "b"):
        code, err = run_main(capsys, "scenes", "random", "--seed", 7, "--out", out)
        assert code == 0 and not err
    a = {p.name: p.read_bytes() for p in (tmp_path / "a").iterdir()}
    assert a == {p.name: p.read_bytes() for p in (tmp_path / "b").iterdir()}
    assert "random_7.toml" in a
    load_scene(tmp_path / "a" / "random_7.toml")


def test_a_bad_seed_is_one_line_and_exit_2(capsys, tmp_path):
    for bad in ("-1", "x", "1.5"):
        code, err = run_main(capsys, "scenes", "random", f"--seed={bad}", "--out", tmp_path)
        assert code == 2 and len(err) == 1 and "--seed" in err[0]
    code, err = run_main(capsys, "scenes", "random", "--out", tmp_path)
    assert code == 2 and len(err) == 1 and "--seed" in err[0]
