"""Builders of hostile files for the CLI tests: GLB and glTF documents, PNGs, npz dumps."""

from __future__ import annotations

import json
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np

from game import gltf
from tests.cli.cli_helpers import MESH
from tests.helpers import TINY as TINY_PATH

TINY = TINY_PATH.read_text()


def glb_with(document_extra: dict, binary: bytes = b"") -> bytes:
    """A GLB holding one triangle, plus ``document_extra`` merged into its JSON."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    indices = np.array([0, 1, 2], np.uint32).tobytes()
    data = positions + indices
    document = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
        "buffers": [{"byteLength": len(data)}],
    }
    for key, value in document_extra.items():
        document[key] = value(document) if callable(value) else value
    return gltf.join_glb(document, data + binary)


def big_png(side: int) -> bytes:
    """A ``side`` x ``side`` black PNG, compressed row by row (never whole in memory)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    packer = zlib.compressobj(9)
    row = b"\0" * (1 + side)
    body = b"".join(packer.compress(row) for _ in range(side)) + packer.flush()
    header = struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", body)
            + chunk(b"IEND", b""))


def mesh_scene(folder: Path, name: str) -> str:
    return TINY + MESH.format(file=name)


# -- files outside the scene's folder --------------------------------------------------------

def npz_declaring(path: Path, arrays: dict[str, np.ndarray], huge: str, shape: tuple) -> None:
    """An npz of ``arrays`` plus member ``huge`` whose header declares ``shape`` of float32 but
    holds a few bytes: np.load would allocate the declared size."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for key, value in arrays.items():
            with z.open(f"{key}.npy", "w") as f:
                np.lib.format.write_array(f, value)
        header = {"descr": "<f4", "fortran_order": False, "shape": shape}
        with z.open(f"{huge}.npy", "w") as f:
            np.lib.format.write_array_header_1_0(f, header)
            f.write(b"\0" * 64)


def gltf_scene(folder: Path, name: str, document: dict, binary: bytes = b"") -> str:
    """Write ``document`` (with ``binary`` for a GLB) as ``name`` inside ``folder``."""
    target = folder / name
    target.parent.mkdir(parents=True, exist_ok=True)
    if name.endswith(".glb"):
        target.write_bytes(gltf.join_glb(document, binary))
    else:
        target.write_text(json.dumps(document))
    return mesh_scene(folder, name)


def one_triangle() -> tuple[dict, bytes]:
    """The document and binary data of :func:`glb_with` without extras."""
    document, binary = gltf.split_glb(glb_with({}))
    return document, binary


def chain_of_nodes(count: int) -> dict:
    document, _ = one_triangle()
    document["nodes"] = [{"mesh": 0, "children": [i + 1]} for i in range(count - 1)]
    document["nodes"].append({"mesh": 0})
    return document




def data_uri_declaring_more() -> dict:
    import base64

    document, binary = one_triangle()
    uri = "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
    document["buffers"] = [{"uri": uri, "byteLength": 10**9}]
    document["bufferViews"][1]["byteLength"] = 1000   # inside what the buffer declares
    return document


def float_indices() -> dict:
    document, _ = one_triangle()
    document["accessors"][1]["componentType"] = 5126
    document["bufferViews"][1]["byteStride"] = 1
    return document


def scene_five() -> dict:
    document, _ = one_triangle()
    document.update(scene=5, scenes=[])
    return document


