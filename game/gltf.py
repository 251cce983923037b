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
from urllib.parse import unquote

GLB_MAGIC = b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
MAX_JSON_BYTES = 64 * 2**20      # a glTF's JSON part; real ones are far smaller
MAX_JSON_DEPTH = 64              # nesting of the JSON, so the parser cannot recurse too deep
# An accessor with no buffer view is all zeros, which the reader allocates: at most this much.
MAX_ZERO_ACCESSOR_BYTES = 64 * 2**20
# Parts that trimesh would decode or resolve but that the geometry does not need.
UNUSED = ("images", "textures", "samplers", "materials")
BASE_COLOUR_COMPONENTS = 4    # a material's baseColorFactor: linear RGBA


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


def check_uris(document: dict, base: Path | None = None, root: Path | None = None) -> list[Path]:
    """Every buffer and image URI must be data, or a relative path from ``base`` (the file's
    folder) that stays inside ``root`` (the scene's folder); with no ``base``, only embedded
    data is allowed. Declared buffer sizes must be whole numbers.

    Returns the outside files the buffers name (images are never read).
    """
    files = []
    for section in ("buffers", "images"):
        entries = document.get(section, [])
        if not isinstance(entries, list):
            raise GltfError(f"'{section}' is not a list")
        for entry in entries:
            if not isinstance(entry, dict):
                raise GltfError(f"an entry of '{section}' is not an object")
            uri = entry.get("uri")
            if uri is None or (isinstance(uri, str) and uri.startswith("data:")):
                continue
            if not isinstance(uri, str):
                raise GltfError(f"a {section} URI is not a string")
            if base is None:
                raise GltfError(f"names an outside file ({section} URI {uri!r}); only embedded "
                                "data is read here")
            target = Path(unquote(uri))
            if "://" in uri or target.is_absolute() or uri.startswith(("/", "\\")):
                raise GltfError(f"{section} URI must be a relative file name: {uri!r}")
            inside = (root or base).resolve()
            full = (base / target).resolve()
            if not full.is_relative_to(inside):
                raise GltfError(f"{section} URI leaves the scene's folder: {uri!r}")
            if section == "buffers":
                files.append(full)
    for entry in document.get("buffers", []):
        size = entry.get("byteLength", 0)
        if not isinstance(size, int) or size < 0:
            raise GltfError("a buffer's byteLength is not a whole number")
    return files


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
    accessors = document.get("accessors", [])
    if not isinstance(accessors, list):
        raise GltfError("'accessors' is not a list")
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


def safe_glb(data: bytes, base: Path | None = None, root: Path | None = None) -> bytes:
    """GLB bytes ready for trimesh: URIs checked (see :func:`check_uris`), unused parts out."""
    document, binary = split_glb(data)
    _checked(check_uris, document, base, root)
    _checked(check_accessors, document, len(binary))
    return join_glb(_checked(geometry_only, document), binary)


def safe_gltf(data: bytes, base: Path, root: Path) -> tuple[bytes, list[Path]]:
    """A .gltf's JSON ready for trimesh, its URIs checked as for :func:`safe_glb`, and the
    buffer files it will read."""
    document = _parse_json(data)
    files = _checked(check_uris, document, base, root)
    _checked(check_accessors, document)
    return json.dumps(_checked(geometry_only, document)).encode(), files
