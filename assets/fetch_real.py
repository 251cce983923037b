"""Fetch real third-party game assets into ``assets/real/`` (git-ignored) and write scenes for them.

    python assets/fetch_real.py [--out DIR] [--cache DIR]

Sources, pinned by version and sha256 (assets/REAL_ASSETS.md lists what each file is):

- the pybullet 3.2.7 wheel from PyPI: the samurai monastery level and two props (duck, teddy);
- the npm packages ``bunny`` 1.0.1 (the Stanford bunny) and ``teapot`` 1.0.0 (the Utah teapot),
  stored as JavaScript arrays and converted to OBJ here.

Downloads are kept in the cache and reused while their sha256 matches. Every output is built in a
temporary folder first and moved into place only when all of it is ready, so a failure (no
network, a corrupt download) leaves no partial file. Failures are one line and exit status 1.
Running it again rewrites the same bytes.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from game.scene.parts import connected_components, median_groups

HERE = Path(__file__).resolve().parent
DEFAULT_OUT = HERE / "real"

WHEEL = "pybullet-3.2.7-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl"
WHEEL_SHA256 = "5d858abf7c12a21ef3ed351cf81dac1b5e486ec25c9ab59bfc84beb89034edff"
# Pin the platform tags so every host downloads this same file, whatever its own Python is.
PIP_ARGS = ["download", "--no-deps", "--only-binary=:all:", "--implementation", "cp",
            "--python-version", "3.11", "--abi", "cp311", "--platform", "manylinux2014_x86_64",
            "pybullet==3.2.7"]

# tarball -> (npm spec, sha256, the module that holds `exports.positions` and `exports.cells`)
NPM = {
    "bunny-1.0.1.tgz": ("bunny@1.0.1",
                        "381e02c74b98cf18814d7bec794726ef70b9c67e037273e82054d0043f6ae303",
                        "package/index.js"),
    "teapot-1.0.0.tgz": ("teapot@1.0.0",
                         "ebe7143533ff1a35ea25738b43112d36fd9ae072652bde9b2144057e7218890f",
                         "package/teapot.js"),
}

LEVEL = "samurai_monastry.obj"
# The same level as separate files, as a user who split it by hand would give it: its connected
# components in this many groups of neighbours (game/scene/parts.py), one OBJ each.
LEVEL_PARTS = 24
# Wheel members copied byte for byte into the output folder, under the same base name.
WHEEL_FILES = ("samurai_monastry.obj", "samurai_monastry.mtl", "duck.obj", "teddy2_VHACD_CHs.obj")
WHEEL_LICENSE = "pybullet-3.2.7.dist-info/LICENSE.txt"
NPM_OBJ = {"bunny-1.0.1.tgz": "bunny.obj", "teapot-1.0.0.tgz": "teapot.obj"}

# The monastery, measured from the pinned file: Y is up already (pybullet's samurai.urdf turns it
# 90 degrees about X into its Z-up world). The walled compound, x in [-35.9, 24.0] and z in
# [-31.0, 31.0], holds its own ground: a sunken courtyard at y = 0 and a platform at y = 1.8. The
# buildings outside it stand on nothing, their bases at y = 1.476. So the scene adds a ground at
# y = 1.47 around the compound, and under the compound a floor just below its courtyard that only
# shows through gaps. Every floor's bottom is below the whole mesh, so no floor lies above it.
GROUND_Y = 1.47
HOLE = (-35.8, 23.9, -30.9, 30.9)     # x0, x1, z0, z1: the compound, left open in the ground
GROUND_HALF = 200.0                   # half the ground's side, out to the horizon
FLOOR_BOTTOM = -0.3


class FetchError(Exception):
    """A failure reported as one line."""


@dataclass(frozen=True)
class Prop:
    """A prop placed standing on the floor: scaled to ``height``, its footprint centred on
    ``(x, z)``, turned by ``yaw`` degrees about Y."""

    file: str
    height: float
    x: float
    z: float
    yaw: float = 0.0


def sha256(path: Path) -> str:
    """The hex sha256 of a file."""
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _reason(result: subprocess.CompletedProcess) -> str:
    """The telling line of a failed download: npm's JSON error summary, or pip's last error."""
    try:
        return str(json.loads(result.stdout)["error"]["summary"])
    except (ValueError, KeyError, TypeError):
        pass
    lines = [line.strip() for line in result.stderr.splitlines() if line.strip()]
    errors = [line.removeprefix("ERROR: ") for line in lines if line.startswith("ERROR:")]
    return (errors or lines or [f"exit status {result.returncode}"])[-1]


def _run(command: list[str], what: str) -> None:
    """Run a download command, failing with one line."""
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=1800)
    except FileNotFoundError:
        raise FetchError(f"{command[0]} not found on PATH (needed to fetch {what})") from None
    except subprocess.TimeoutExpired:
        raise FetchError(f"fetching {what} timed out") from None
    if result.returncode != 0:
        raise FetchError(f"fetching {what} failed: {_reason(result)}")


def cached(cache: Path, name: str, expected: str, download: Callable[[Path], None]) -> Path:
    """``cache/name`` with sha256 ``expected``: reused if present, else downloaded by
    ``download(folder)`` into a temporary folder, checked, then moved into the cache."""
    target = cache / name
    if target.is_file() and sha256(target) == expected:
        return target
    cache.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache, prefix=".download-") as folder:
        download(Path(folder))
        got = Path(folder) / name
        if not got.is_file():
            raise FetchError(f"download did not produce {name}")
        actual = sha256(got)
        if actual != expected:
            raise FetchError(f"sha256 mismatch for {name}: got {actual}, expected {expected}")
        os.replace(got, target)
    return target


def fetch(cache: Path) -> tuple[Path, dict[str, Path]]:
    """The pybullet wheel and the npm tarballs, from the cache or downloaded into it."""
    wheel = cached(cache, WHEEL, WHEEL_SHA256, lambda folder: _run(
        [sys.executable, "-m", "pip", *PIP_ARGS, "-d", str(folder)], "pybullet==3.2.7 from PyPI"))
    tarballs = {}
    for name, (spec, digest, _) in NPM.items():
        tarballs[name] = cached(cache, name, digest, lambda folder, spec=spec: _run(
            ["npm", "pack", spec, "--json", "--fetch-retries=1", "--pack-destination", str(folder)],
            f"{spec} from npm"))
    return wheel, tarballs


def _wheel_member(archive: zipfile.ZipFile, member: str, wheel: Path) -> bytes:
    try:
        return archive.read(member)   # checks the CRC
    except KeyError:
        raise FetchError(f"{wheel.name} has no {member}") from None
    except (zipfile.BadZipFile, OSError, EOFError) as error:
        raise FetchError(f"{wheel.name}: cannot read {member}: {error}") from None


def _npm_mesh(tarball: Path, module: str) -> tuple[trimesh.Trimesh, str]:
    """The mesh in an npm package's ``exports.positions`` / ``exports.cells``, and the licence
    its package.json states."""
    try:
        with tarfile.open(tarball, "r:gz") as archive:
            text = archive.extractfile(module).read().decode("utf-8")
            package = json.loads(archive.extractfile("package/package.json").read())
    except (tarfile.TarError, KeyError, AttributeError, OSError, EOFError, UnicodeDecodeError,
            json.JSONDecodeError) as error:
        raise FetchError(f"{tarball.name}: cannot read {module}: {error}") from None
    arrays = {}
    for chunk in text.split("exports.")[1:]:
        key, _, value = chunk.partition("=")
        try:
            arrays[key.strip()] = json.loads(value.strip().rstrip(";"))
        except json.JSONDecodeError:
            raise FetchError(f"{tarball.name}: {module}: exports.{key.strip()} is not "
                             f"a JSON array") from None
    try:
        vertices = np.asarray(arrays["positions"], dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(arrays["cells"], dtype=np.int64).reshape(-1, 3)
    except (KeyError, ValueError, TypeError):
        raise FetchError(f"{tarball.name}: {module} holds no positions and cells") from None
    if len(faces) == 0 or faces.min() < 0 or faces.max() >= len(vertices):
        raise FetchError(f"{tarball.name}: {module}: bad face indices")
    return trimesh.Trimesh(vertices, faces, process=False), str(package.get("license", "none"))


def _obj_text(mesh: trimesh.Trimesh, source: str) -> str:
    lines = [f"# {source}, converted to OBJ by assets/fetch_real.py"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in mesh.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces]
    return "\n".join(lines) + "\n"


def _load_obj(path: Path) -> trimesh.Trimesh:
    """Load as the scene loader does (materials skipped), failing on a file with no triangles."""
    try:
        mesh = trimesh.load(str(path), file_type="obj", force="mesh", process=False,
                            skip_materials=True)
    except Exception as error:  # noqa: BLE001 - trimesh raises anything on a corrupt file
        raise FetchError(f"cannot read {path.name}: {error}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise FetchError(f"no triangles in {path.name}")
    return mesh


def _vec(values) -> str:
    return "[" + ", ".join(repr(round(float(v), 4)) for v in values) + "]"


def _floor(size, position) -> str:
    return f'[[floor]]\nshape    = "box"\nsize     = {_vec(size)}\nposition = {_vec(position)}\n'


def _static(prop: Prop, mesh: trimesh.Trimesh) -> str:
    """A static that stands ``mesh`` on y = 0 as ``prop`` says: scale, then yaw, then move."""
    lo, hi = mesh.bounds
    scale = prop.height / max(hi[1] - lo[1], 1e-9)
    base = scale * np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
    yaw = np.radians(prop.yaw)
    turn = np.array([[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0], [-np.sin(yaw), 0, np.cos(yaw)]])
    position = np.array([prop.x, 0.0, prop.z]) - turn @ base
    return (f'[[static]]\nshape    = "mesh"\nfile     = "{prop.file}"\n'
            f"scale    = {round(float(scale), 6)!r}\nrotation = {_vec([0, prop.yaw, 0])}\n"
            f"position = {_vec(position)}\n")


def level_part_files(level: trimesh.Trimesh) -> dict[str, str]:
    """The level's connected components in ``LEVEL_PARTS`` groups of neighbours: OBJ texts."""
    faces = np.asarray(level.faces)
    components = connected_components(level.vertices, faces)
    n = int(components.max()) + 1
    centres = np.zeros((n, 3))
    np.add.at(centres, components, np.asarray(level.vertices)[faces].mean(axis=1))
    centres /= np.bincount(components, minlength=n)[:, None]
    groups = median_groups(centres, LEVEL_PARTS)[components]
    texts = {}
    for g in range(int(groups.max()) + 1):
        part = level.submesh([np.flatnonzero(groups == g)], append=True)
        texts[f"monastery_part_{g:02d}.obj"] = _obj_text(
            part, f"pybullet 3.2.7, pybullet_data/{LEVEL}, part {g} of {LEVEL_PARTS}")
    return texts


def monastery_scene(parts: list[str] | None = None) -> str:
    """The level: ground around the walled compound, a low sun, a camera high on its +x +z side;
    the level as one file, or as the files ``parts``."""
    x0, x1, z0, z1 = HOLE
    e, depth = GROUND_HALF, GROUND_Y - FLOOR_BOTTOM
    mid = GROUND_Y - depth / 2

    def ground(xa: float, xb: float, za: float, zb: float) -> str:
        return _floor([xb - xa, depth, zb - za], [(xa + xb) / 2, mid, (za + zb) / 2])

    inner = -0.05 - FLOOR_BOTTOM   # its top 3 cm below the courtyard's lowest point, y = -0.02
    return (
        "# The samurai monastery from the pybullet 3.2.7 wheel (pybullet_data/samurai_monastry.obj)"
        "\n# on a ground around its walled compound"
        + (f", split into {len(parts)} files" if parts else "")
        + ". Written by assets/fetch_real.py; see\n# assets/REAL_ASSETS.md.\n"
        + ('name = "monastery_parts"\n\n' if parts else 'name = "monastery"\n\n')
        + "[camera]\nposition = [18.0, 40.0, 90.0]\ntarget   = [-6.0, 0.0, 2.0]\nfov      = 55.0\n"
        "near     = 0.5\nfar      = 400.0\n\n"
        '[light]\nkind      = "directional"\ndirection = [0.75, -0.5, -0.35]\n'
        'color     = [1.0, 0.97, 0.92]  # the warm sun\n\n'
        "[linear_light]\na = [-60.0, 90.0, 40.0]\nb = [-20.0, 90.0, -40.0]\n\n"
        "# The ground, in four strips around the compound.\n"
        + ground(-e, e, -e, z0) + "\n" + ground(-e, e, z1, e) + "\n"
        + ground(-e, x0, z0, z1) + "\n" + ground(x1, e, z0, z1) + "\n"
        "# Under the compound, below its own courtyard.\n"
        + _floor([x1 - x0, inner, z1 - z0], [(x0 + x1) / 2, FLOOR_BOTTOM + inner / 2,
                                               (z0 + z1) / 2])
        + "".join(f'\n[[static]]\nshape = "mesh"\nfile  = "{name}"\n'
                  for name in (parts or [LEVEL]))
    )


# The spot light's axis runs through the teddy: the duck stands between it and the light, the
# bunny in its shadow. The point light is surrounded, with a smaller copy behind two props.
PROPS_SPOT = [Prop("duck.obj", 1.3, 1.9, 1.6, -30.0), Prop("teddy2_VHACD_CHs.obj", 1.5, 0.0, 0.0),
              Prop("bunny.obj", 1.3, -1.6, -1.3, 30.0), Prop("teapot.obj", 0.9, 1.9, -1.2),
              Prop("teapot.obj", 0.6, -2.2, 1.2, 120.0)]
PROPS_POINT = [Prop("duck.obj", 1.2, 2.6, 0.0, 180.0), Prop("teddy2_VHACD_CHs.obj", 1.4, 0.0, -2.6),
               Prop("bunny.obj", 1.2, -2.6, 0.2, 90.0), Prop("teapot.obj", 0.8, 0.2, 2.6),
               Prop("duck.obj", 0.9, 3.9, 0.2, 160.0), Prop("bunny.obj", 0.9, -3.9, 0.4, 45.0)]


def props_scene(kind: str, meshes: dict[str, trimesh.Trimesh]) -> str:
    """Real props standing on a floor, lit by a spot light or a point light."""
    if kind == "spot":
        props, head = PROPS_SPOT, (
            "[camera]\nposition = [-2.0, 4.0, 7.0]\ntarget   = [0.0, 0.4, -0.5]\nfov      = 55.0\n"
            "\n[light]\nkind      = \"spot\"\nposition  = [6.0, 5.0, 5.0]\n"
            "direction = [-6.0, -5.0, -5.0]\ncone      = 60.0\n")
    else:
        props, head = PROPS_POINT, (
            "[camera]\nposition = [0.0, 6.5, 8.0]\ntarget   = [0.0, 0.3, 0.0]\nfov      = 60.0\n"
            "\n[light]\nkind     = \"point\"\nposition = [0.0, 3.5, 0.0]\n")
    return (f"# Real props (pybullet 3.2.7 wheel, npm bunny 1.0.1 and teapot 1.0.0) on a floor,\n"
            f"# lit by a {kind} light. Written by assets/fetch_real.py, see assets/REAL_ASSETS.md\n"
            f'name = "props_{kind}"\n\n{head}\n'
            + _floor([30.0, 0.2, 30.0], [0.0, -0.1, 0.0]) + "\n"
            + "\n".join(_static(prop, meshes[prop.file]) for prop in props))


def _build_into(work: Path, wheel: Path, tarballs: dict[str, Path]) -> list[str]:
    """Write every output file into the empty folder ``work``; returns their names."""
    manifest: dict[str, dict] = {}
    try:
        archive = zipfile.ZipFile(wheel)
    except (zipfile.BadZipFile, OSError) as error:
        raise FetchError(f"{wheel.name} is not a readable wheel: {error}") from None
    with archive:
        for name in WHEEL_FILES:
            (work / name).write_bytes(_wheel_member(archive, f"pybullet_data/{name}", wheel))
            manifest[name] = {"source": wheel.name, "member": f"pybullet_data/{name}"}
        (work / "LICENSE-pybullet.txt").write_bytes(_wheel_member(archive, WHEEL_LICENSE, wheel))
        manifest["LICENSE-pybullet.txt"] = {"source": wheel.name, "member": WHEEL_LICENSE}
    for tarball_name, obj in NPM_OBJ.items():
        spec, _, module = NPM[tarball_name]
        mesh, licence = _npm_mesh(tarballs[tarball_name], module)
        (work / obj).write_text(_obj_text(mesh, f"npm {spec}, {module}"), encoding="utf-8")
        manifest[obj] = {"source": tarballs[tarball_name].name, "member": module,
                         "license": licence}
    meshes = {name: _load_obj(work / name) for name in manifest if name.endswith(".obj")}
    for name, mesh in meshes.items():
        manifest[name]["triangles"] = len(mesh.faces)
    parts = level_part_files(meshes[LEVEL])
    for name, text in parts.items():
        (work / name).write_text(text, encoding="utf-8")
        manifest[name] = {"source": wheel.name, "member": f"pybullet_data/{LEVEL}",
                          "triangles": text.count("\nf ")}
    scenes = {"monastery.toml": monastery_scene(),
              "monastery_parts.toml": monastery_scene(sorted(parts)),
              "props_spot.toml": props_scene("spot", meshes),
              "props_point.toml": props_scene("point", meshes)}
    for name, text in scenes.items():
        (work / name).write_text(text, encoding="utf-8")
        manifest[name] = {"source": "assets/fetch_real.py"}
    for name in manifest:
        manifest[name]["sha256"] = sha256(work / name)
    (work / "manifest.json").write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n",
                                        encoding="utf-8")
    return [*manifest, "manifest.json"]


def build(wheel: Path, tarballs: dict[str, Path], out: Path) -> list[Path]:
    """Extract the meshes, convert the npm ones, write the scenes and a manifest into ``out``.

    Nothing in ``out`` changes unless every file was built; the files are then moved in one by
    one, replacing earlier copies. The work folder is inside ``out``, so a run that is killed
    leaves its debris in the git-ignored folder. Returns the paths written.
    """
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    try:
        with tempfile.TemporaryDirectory(dir=out, prefix=".build-") as folder:
            names = _build_into(Path(folder), wheel, tarballs)
            for name in names:
                os.replace(Path(folder) / name, out / name)
    except BaseException:
        if created and not any(out.iterdir()):
            out.rmdir()
        raise
    return [out / name for name in names]


def _default_cache() -> Path:
    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "shadowgame" / "real-assets"


def main(argv: list[str] | None = None) -> int:
    """Fetch (or reuse) the packages, then build the output folder."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"output folder (default: {DEFAULT_OUT})")
    parser.add_argument("--cache", type=Path, default=_default_cache(),
                        help="where downloads are kept and reused (default: %(default)s)")
    args = parser.parse_args(argv)
    try:
        wheel, tarballs = fetch(args.cache)
        written = build(wheel, tarballs, args.out)
    except FetchError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except OSError as error:
        print(f"error: {error.strerror or error}: {error.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return 1
    print(f"wrote {len(written)} files to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
