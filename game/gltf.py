"""glTF and GLB files read without trusting them: every URI checked, nothing decoded that is not
used, sizes checked before anything is read.

trimesh resolves the URIs a glTF or GLB names (its buffers and images) and decodes every image,
whatever its version; a file could so make it read files anywhere, or unpack a few kilobytes
of PNG into gigabytes. Here the JSON is read first, its URIs are checked, and what trimesh gets
is the same file with its images, textures and samplers taken out, and each material cut down to
its base colour factor (four numbers): the geometry and the parts' colours are all the renderer
and the reference use.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import BinaryIO, NamedTuple
from urllib.parse import unquote

GLB_MAGIC = b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
MAX_JSON_BYTES = 64 * 2**20      # a glTF's JSON part; real ones are far smaller
MAX_JSON_DEPTH = 64              # nesting of the JSON, so the parser cannot recurse too deep
# Accessors with no buffer view are all zeros, which the reader allocates: at most this much
# in all.
MAX_ZERO_ACCESSOR_BYTES = 64 * 2**20
# Parts that trimesh would decode or resolve but that the geometry does not need.
UNUSED = ("images", "textures", "samplers", "materials")
BASE_COLOUR_COMPONENTS = 4    # a material's baseColorFactor: linear RGBA
# The node tree is walked once, each node at most once; these bound that walk and the scene
# graph trimesh builds from it (it finds each mesh's transform by its path to the root).
MAX_NODES = 16_384
MAX_NODE_DEPTH = 128
INDEX_TYPES = (5121, 5123, 5125)   # unsigned byte, short and int: the only index types


class GltfError(ValueError):
    """A glTF or GLB that cannot be read safely; the message is one line."""


def _depth_ok(text: str) -> bool:
    """Whether JSON ``text`` nests at most :data:`MAX_JSON_DEPTH` deep (strings skipped)."""
    depth, in_string, escaped = 0, False, False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            if depth > MAX_JSON_DEPTH:
                return False
        elif ch in "]}":
            depth -= 1
    return True


def _parse_json(raw: bytes) -> dict:
    if len(raw) > MAX_JSON_BYTES:
        raise GltfError(f"its JSON part is {len(raw)} bytes, more than {MAX_JSON_BYTES}")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise GltfError("its JSON part is not UTF-8 text") from None
    if not _depth_ok(text):
        raise GltfError(f"its JSON nests deeper than {MAX_JSON_DEPTH} levels")
    try:
        document = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as error:
        raise GltfError(f"its JSON is not valid ({error})") from None
    except ValueError:  # an integer of more digits than Python converts
        raise GltfError("its JSON holds a number too long to read") from None
    if not isinstance(document, dict):
        raise GltfError("its JSON is not an object")
    return document


def split_glb(data: bytes) -> tuple[dict, bytes]:
    """A GLB's JSON document and its binary chunk (empty if none), after checking the header and
    the chunk lengths against the data."""
    if len(data) < 20 or data[:4] != GLB_MAGIC:
        raise GltfError("not a GLB file (no glTF header)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise GltfError(f"GLB version {version}; only version 2 is read")
    if length > len(data):
        raise GltfError(f"the header declares {length} bytes, the file has {len(data)}")
    chunk_length, chunk_type = struct.unpack_from("<II", data, 12)
    if chunk_type != CHUNK_JSON or 20 + chunk_length > length:
        raise GltfError("its first chunk is not a whole JSON chunk")
    document = _parse_json(data[20:20 + chunk_length])
    binary = b""
    offset = 20 + chunk_length
    if offset + 8 <= length:
        bin_length, bin_type = struct.unpack_from("<II", data, offset)
        if bin_type == CHUNK_BIN:
            if offset + 8 + bin_length > length:
                raise GltfError("its binary chunk runs past the end of the file")
            binary = data[offset + 8:offset + 8 + bin_length]
    return document, binary


def check_uris(document: dict, base: Path | None = None,
               root: Path | None = None) -> list[tuple[str, Path, int]]:
    """Every buffer and image URI must be data, or a relative path from ``base`` (the file's
    folder) that stays inside ``root`` (the scene's folder); with no ``base``, only embedded
    data is allowed. Declared buffer sizes must be whole numbers, and embedded data must hold
    what its buffer declares.

    Returns the outside files the buffers name (images are never read): each URI as written,
    its path and the bytes its buffer declares.
    """
    files = []
    for section in ("buffers", "images"):
        entries = document.get(section, [])
        if not isinstance(entries, list):
            raise GltfError(f"'{section}' is not a list")
        for number, entry in enumerate(entries):
            if not isinstance(entry, dict):
                raise GltfError(f"an entry of '{section}' is not an object")
            declared = entry.get("byteLength", 0) if section == "buffers" else 0
            if not isinstance(declared, int) or isinstance(declared, bool) or declared < 0:
                raise GltfError("a buffer's byteLength is not a whole number")
            uri = entry.get("uri")
            if isinstance(uri, str) and uri.startswith("data:"):
                held = _data_uri_bytes(uri)
                if declared > held:
                    raise GltfError(f"buffer {number} declares {declared:,} bytes; its data "
                                    f"holds {held:,}")
                continue
            if uri is None:
                continue
            full = _uri_path(section, uri, base, root)
            if section == "buffers":
                files.append((uri, full, declared))
    return files


def _data_uri_bytes(uri: str) -> int:
    """How many bytes a data URI holds, from its text (nothing is decoded)."""
    head, _, payload = uri.partition(",")
    if head.endswith(";base64"):
        payload = payload.strip()
        return len(payload) * 3 // 4 - len(payload) + len(payload.rstrip("="))
    return len(unquote(payload).encode("utf-8", "surrogateescape"))


def _uri_path(section: str, uri, base: Path | None, root: Path | None) -> Path:
    """The file a URI names, if it stays inside the scene's folder."""
    if not isinstance(uri, str):
        raise GltfError(f"a {section} URI is not a string")
    if base is None:
        raise GltfError(f"names an outside file ({section} URI {uri!r}); only embedded "
                        "data is read here")
    target = Path(unquote(uri))
    if "://" in uri or target.is_absolute() or uri.startswith(("/", "\\")):
        raise GltfError(f"{section} URI must be a relative file name: {uri!r}")
    full = (base / target).resolve()
    if not full.is_relative_to((root or base).resolve()):
        raise GltfError(f"{section} URI leaves the scene's folder: {uri!r}")
    return full


def check_accessors(document: dict, binary_length: int | None = None) -> None:
    """Every accessor must fit in its buffer view and every view in its buffer, so that no
    declared count makes a reader allocate more than the file holds."""
    sizes = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
    component = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
    buffers = document.get("buffers", [])
    views = document.get("bufferViews", [])
    if not isinstance(views, list) or not isinstance(buffers, list):
        raise GltfError("'bufferViews' or 'buffers' is not a list")
    for view in views:
        if not isinstance(view, dict) or not isinstance(view.get("buffer"), int):
            raise GltfError("a buffer view names no buffer")
        index, length = view["buffer"], view.get("byteLength")
        offset = view.get("byteOffset", 0)
        if not (0 <= index < len(buffers)) or not isinstance(length, int) \
                or not isinstance(offset, int) or length < 0 or offset < 0:
            raise GltfError("a buffer view is not whole numbers inside its buffer")
        declared = buffers[index].get("byteLength", 0) if isinstance(buffers[index], dict) else 0
        if index == 0 and binary_length is not None and "uri" not in buffers[index]:
            declared = min(declared, binary_length)
        if offset + length > declared:
            raise GltfError("a buffer view runs past the end of its buffer")
        stride = view.get("byteStride")
        if stride is not None and not (isinstance(stride, int) and 4 <= stride <= 252
                                       and stride % 4 == 0):
            raise GltfError(f"a buffer view's byteStride {stride!r} is not allowed (glTF "
                            "allows 4 to 252, in steps of 4)")
    accessors = document.get("accessors", [])
    if not isinstance(accessors, list):
        raise GltfError("'accessors' is not a list")
    zeros = 0
    for accessor in accessors:
        if not isinstance(accessor, dict):
            raise GltfError("an accessor is not an object")
        count = accessor.get("count")
        width = sizes.get(accessor.get("type")), component.get(accessor.get("componentType"))
        if not isinstance(count, int) or count < 0 or None in width:
            raise GltfError("an accessor has no valid count, type or component type")
        view = accessor.get("bufferView")
        if view is None:  # all zeros, made by the reader: bound what it would allocate
            if count * width[0] * width[1] > MAX_ZERO_ACCESSOR_BYTES:
                raise GltfError(f"an accessor without data declares {count:,} elements")
            zeros += count * width[0] * width[1]
            if zeros > MAX_ZERO_ACCESSOR_BYTES:
                raise GltfError(f"its accessors without data declare more than "
                                f"{MAX_ZERO_ACCESSOR_BYTES // 2**20} MiB in all")
            continue
        if not isinstance(view, int) or not 0 <= view < len(views):
            raise GltfError("an accessor names a buffer view that does not exist")
        stride = views[view].get("byteStride") or width[0] * width[1]
        offset = accessor.get("byteOffset", 0)
        if not (isinstance(stride, int) and stride > 0 and isinstance(offset, int)
                and offset >= 0):
            raise GltfError("an accessor's byteOffset or its view's byteStride is not a whole "
                            "number")
        need = offset + max(count - 1, 0) * stride + width[0] * width[1]
        if count and need > views[view]["byteLength"]:
            raise GltfError(f"an accessor declares {count:,} elements, more than its buffer "
                            "view holds")


def _index(value, items: list, what: str) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < len(items):
        raise GltfError(f"{what} {value!r} is not one of the file's {len(items)}")
    return value


def _mesh_cost(mesh, accessors: list) -> tuple[int, int, int]:
    """The triangles, vertices and primitives one placement of ``mesh`` adds; its index
    accessors must be unsigned integers."""
    triangles = vertices = 0
    primitives = mesh.get("primitives", []) if isinstance(mesh, dict) else None
    if not isinstance(primitives, list):
        raise GltfError("a mesh's 'primitives' is not a list")
    for primitive in primitives:
        if not isinstance(primitive, dict) or not isinstance(primitive.get("attributes"), dict):
            raise GltfError("a mesh primitive has no attributes")
        position = primitive["attributes"].get("POSITION")
        count = 0 if position is None else \
            accessors[_index(position, accessors, "a POSITION accessor")]["count"]
        vertices += count
        if "indices" in primitive:
            accessor = accessors[_index(primitive["indices"], accessors, "an indices accessor")]
            if accessor.get("componentType") not in INDEX_TYPES or accessor["type"] != "SCALAR":
                raise GltfError(f"a primitive's indices (accessor {primitive['indices']}) must "
                                "be unsigned integers, one a vertex")
            count = accessor["count"]
        mode = primitive.get("mode", 4)
        triangles += count // 3 if mode == 4 else max(count - 2, 0) if mode in (5, 6) else 0
    return triangles, vertices, len(primitives)


def check_tree(document: dict, count_nodes: bool = True) -> tuple[int, int, int]:
    """The triangles, vertices and mesh primitives the file's scene draws, each mesh counted
    once for every node that places it, after checking its scene index, every mesh and the
    node tree: at most :data:`MAX_NODES` nodes (with ``count_nodes``), nested at most
    :data:`MAX_NODE_DEPTH` deep, each node in one place. The tree is walked once, in time
    linear in its nodes."""
    nodes, meshes = document.get("nodes", []), document.get("meshes", [])
    scenes, accessors = document.get("scenes", []), document.get("accessors", [])
    for name, value in (("nodes", nodes), ("meshes", meshes), ("scenes", scenes)):
        if not isinstance(value, list):
            raise GltfError(f"'{name}' is not a list")
    if count_nodes and len(nodes) > MAX_NODES:
        raise GltfError(f"it has {len(nodes):,} nodes, more than the {MAX_NODES:,} a glTF "
                        "may have")
    if "scene" in document or scenes:
        scene = document.get("scene", 0)
        if not isinstance(scene, int) or isinstance(scene, bool) \
                or not 0 <= scene < len(scenes):
            raise GltfError(f"'scene' is {scene!r}, but the file has {len(scenes)} scenes")
    roots = scenes[document.get("scene", 0)].get("nodes", []) if scenes else []
    if not isinstance(roots, list):
        raise GltfError("a scene's 'nodes' is not a list")
    costs = [_mesh_cost(mesh, accessors) for mesh in meshes]   # every mesh: trimesh reads all
    placed = bytearray(len(nodes))
    drawn = [0, 0, 0]
    stack = [(root, 1) for root in reversed(roots)]
    while stack:
        index, depth = stack.pop()
        index = _index(index, nodes, "a node")
        if placed[index]:
            raise GltfError(f"node {index} has more than one parent (glTF nodes form trees)")
        if depth > MAX_NODE_DEPTH:
            raise GltfError(f"its nodes nest deeper than {MAX_NODE_DEPTH} levels")
        placed[index] = 1
        node = nodes[index]
        if "mesh" in node:
            mesh = _index(node["mesh"], meshes, "a node's mesh")
            drawn = [total + cost for total, cost in zip(drawn, costs[mesh], strict=True)]
        children = node.get("children", [])
        if not isinstance(children, list):
            raise GltfError(f"node {index}'s 'children' is not a list")
        stack.extend((child, depth + 1) for child in reversed(children))
    return drawn[0], drawn[1], drawn[2]


def _check_drawn(document: dict, most: int | None) -> tuple[int, int]:
    """The triangles and vertices the tree draws, once it is sound and, with ``most`` (a
    scene's mesh file), has at most :data:`MAX_NODES` nodes and draws at most ``most``
    triangles and vertices. A dump's GLB holds a node for each object of its scene, however
    many; flat, they load in linear time."""
    triangles, vertices, pieces = check_tree(document, count_nodes=most is not None)
    if most is not None and pieces > MAX_NODES:
        # trimesh makes a scene-graph node and a copy of the mesh for each placed primitive
        raise GltfError(f"its nodes place {pieces:,} mesh primitives, more than the "
                        f"{MAX_NODES:,} a glTF may place")
    if most is not None:
        for count, what in ((triangles, "triangles"), (vertices, "vertices")):
            if count > most:
                raise GltfError(f"its nodes draw {count:,} {what}, counting every placement of "
                                f"a mesh; more than the {most:,} a mesh file may draw")
    return triangles, vertices


def base_colour(material) -> list[float] | None:
    """A material's ``pbrMetallicRoughness.baseColorFactor`` if it is four numbers in [0, 1]."""
    pbr = material.get("pbrMetallicRoughness") if isinstance(material, dict) else None
    factor = pbr.get("baseColorFactor") if isinstance(pbr, dict) else None
    if (isinstance(factor, list) and len(factor) == BASE_COLOUR_COMPONENTS
            and all(isinstance(v, int | float) and not isinstance(v, bool) and 0.0 <= v <= 1.0
                    for v in factor)):
        return [float(v) for v in factor]
    return None


def geometry_only(document: dict) -> dict:
    """The document without :data:`UNUSED` parts, and its materials as base colours alone.

    A primitive keeps its material only when that material has a valid base colour factor:
    trimesh then reads nothing but those four numbers.
    """
    out = {k: v for k, v in document.items() if k not in UNUSED}
    materials = document.get("materials")
    factors = ([base_colour(m) for m in materials] if isinstance(materials, list) else [])
    kept = {i: n for n, i in enumerate(i for i, f in enumerate(factors) if f is not None)}
    if kept:
        out["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": factors[i]}}
                            for i in kept]

    def primitive(p):
        if not isinstance(p, dict):
            return p
        plain = {k: v for k, v in p.items() if k != "material"}
        index = p.get("material")
        if isinstance(index, int) and not isinstance(index, bool) and index in kept:
            plain["material"] = kept[index]
        return plain

    meshes = []
    for mesh in out.get("meshes", []) or []:
        if isinstance(mesh, dict) and isinstance(mesh.get("primitives"), list):
            mesh = {**mesh, "primitives": [primitive(p) for p in mesh["primitives"]]}
        meshes.append(mesh)
    if meshes:
        out["meshes"] = meshes
    return out


def join_glb(document: dict, binary: bytes) -> bytes:
    """A GLB of ``document`` and ``binary`` (the inverse of :func:`split_glb`)."""
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), CHUNK_JSON) + text
    if binary:
        binary += b"\0" * (-len(binary) % 4)
        chunks += struct.pack("<II", len(binary), CHUNK_BIN) + binary
    return GLB_MAGIC + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def _checked(check, *args):
    """Run a check; a field of the wrong type anywhere is one GltfError, not a TypeError."""
    try:
        return check(*args)
    except (TypeError, KeyError, AttributeError, IndexError, OverflowError) as error:
        raise GltfError(f"malformed glTF fields ({type(error).__name__}: {error})") from None


class Checked(NamedTuple):
    """A glTF or GLB ready for trimesh (:func:`checked`), and what it draws."""

    data: bytes                         # the GLB, or the .gltf's JSON, unused parts out
    files: list[tuple[str, Path, int]]  # the buffer files it will read (:func:`check_uris`)
    triangles: int                      # counting every placement of a mesh by its nodes
    vertices: int


def checked(data: bytes, glb: bool, base: Path | None = None, root: Path | None = None,
            most: int | None = None) -> Checked:
    """A GLB (``glb``) or a .gltf's JSON ready for trimesh: URIs checked (see
    :func:`check_uris`), the node tree checked (with ``most``, what it draws:
    :func:`check_tree`), unused parts out."""
    document, binary = split_glb(data) if glb else (_parse_json(data), None)
    files = _checked(check_uris, document, base, root)
    _checked(check_accessors, document, None if binary is None else len(binary))
    triangles, vertices = _checked(_check_drawn, document, most)
    plain = _checked(geometry_only, document)
    out = join_glb(plain, binary) if glb else json.dumps(plain).encode()
    return Checked(out, files, triangles, vertices)


def safe_glb(data: bytes, base: Path | None = None, root: Path | None = None,
             most: int | None = None) -> bytes:
    """GLB bytes ready for trimesh (:func:`checked`)."""
    return checked(data, True, base, root, most).data


def drawn(stream: BinaryIO, glb: bool, most: int) -> tuple[int, int]:
    """The triangles and vertices a glTF (a GLB with ``glb``) read from ``stream`` draws,
    counting every placement of a mesh by its nodes, from its JSON alone: a GLB's binary chunk
    is not read. Raises GltfError where the file is not sound or draws more than ``most``."""
    if glb:
        head = stream.read(20)
        if len(head) < 20 or head[:4] != GLB_MAGIC:
            raise GltfError("not a GLB file (no glTF header)")
        length, kind = struct.unpack_from("<II", head, 12)
        if kind != CHUNK_JSON:
            raise GltfError("its first chunk is not a JSON chunk")
        text = stream.read(min(length, MAX_JSON_BYTES + 1))
    else:
        text = stream.read(MAX_JSON_BYTES + 1)
    return _checked(_check_drawn, _parse_json(text), most)
