"""The blocks are declared once (game/gpu/blocks.py): the GLSL is generated from the numpy dtypes,
and here the driver itself says where it put every member, which must be where the dtype puts
it. No shader declares a block of its own."""

from __future__ import annotations

import ctypes
import re

import numpy as np
import pytest

from game.gpu import blocks, glsl
from tests.helpers import ROOT

OFFSET_QUERIES = ("GL_OFFSET", "GL_TOP_LEVEL_ARRAY_STRIDE", "GL_ARRAY_STRIDE")


def _resources(program, interface) -> dict[str, dict[str, int]]:
    """Every active resource of ``interface`` in a linked program: name -> its offsets."""
    from OpenGL import GL

    names = [q for q in OFFSET_QUERIES  # uniforms have no top-level array stride
             if not (interface == GL.GL_UNIFORM and q == "GL_TOP_LEVEL_ARRAY_STRIDE")]
    props = [getattr(GL, q) for q in names]
    count = GL.glGetProgramInterfaceiv(program, interface, GL.GL_ACTIVE_RESOURCES)
    out = {}
    for i in range(count):
        name = ctypes.create_string_buffer(256)
        length = GL.GLsizei(0)
        GL.glGetProgramResourceName(program, interface, i, 256, ctypes.byref(length), name)
        values = (GL.GLint * len(props))()
        GL.glGetProgramResourceiv(program, interface, i, len(props),
                                  (GL.GLenum * len(props))(*props), len(props),
                                  ctypes.byref(length), values)
        out[name.value.decode()] = dict(zip(names, values, strict=True))
    return out


def _scalar(glsl_type: str, expr: str) -> str:
    """A float expression reading one component of ``expr``, a value of ``glsl_type``."""
    if glsl_type == "mat4":
        return f"{expr}[0].x"
    if glsl_type[-1].isdigit():
        return f"float({expr}.x)"
    return f"float({expr})"


def _touch(item, structs: dict) -> str:
    """One statement that reads (or, for a write-only buffer, writes) a member of ``item``, so
    the driver counts the block as active."""
    if item.array is None:
        first = item.dtype.names[0]
        glsl_type = blocks.glsl_type(item.dtype.fields[first][0])[0]
        return f"    sink += {_scalar(glsl_type, f'{item.instance}.{first}')};"
    element, member, _ = item.array
    expr, glsl_type = f"{member}[0]", element
    if element in structs:
        first = structs[element].names[0]
        expr += f".{first}"
        glsl_type = blocks.glsl_type(structs[element].fields[first][0])[0]
    if item.access == "writeonly":
        return f"    {expr} = {glsl_type}(0);"
    return f"    sink += {_scalar(glsl_type, expr)};"


def _free_storage_binding(items) -> int:
    used = {b.binding for b in items if isinstance(b, blocks.Block) and b.kind == "buffer"}
    return min(set(range(blocks.MIN_GL_BINDINGS["buffer"])) - used)


def _program(ctx, group: str):
    items = blocks.GROUPS[group]
    structs = {s.name: s.dtype for s in items if isinstance(s, blocks.Struct)}
    touches = [_touch(b, structs) for b in items if isinstance(b, blocks.Block)]
    source = "\n".join([
        "#version 430", f"#define MAX_MAPS {blocks.max_maps(ctx)}",
        f"#define MAX_LIGHTS {blocks.MAX_LIGHTS}", f'#include "{group}"',
        "layout(local_size_x = 1) in;",
        f"layout(std430, binding = {_free_storage_binding(items)}) buffer Sink "
        "{ float sink_out[]; };",
        "void main() {", "    float sink = 0.0;", *touches, "    sink_out[0] = sink;", "}"])
    return ctx.compute_shader(glsl.preprocess(source, name=group))


SCALAR_BYTES = {"int": 4, "uint": 4, "float": 4}


def _expected(dtype: np.dtype, prefix: str, base: int = 0) -> dict[str, int]:
    return {f"{prefix}{name}": base + dtype.fields[name][1]
            for name in dtype.names if not name.startswith("_pad")}


def check_group(ctx, group: str) -> None:
    """Assert that the driver put every member of the group's blocks where the dtype does."""
    from OpenGL import GL

    prog = _program(ctx, group)
    try:
        uniforms = _resources(prog.glo, GL.GL_UNIFORM)
        variables = _resources(prog.glo, GL.GL_BUFFER_VARIABLE)
        checked = 0
        for item in blocks.GROUPS[group]:
            if not isinstance(item, blocks.Block):
                continue
            if item.array is None:  # members read as instance.member
                for name, offset in _expected(item.dtype, f"{item.name}.").items():
                    assert uniforms[name]["GL_OFFSET"] == offset, name
                    checked += 1
                continue
            element, member, _ = item.array
            struct = next((s for s in blocks.GROUPS[group]
                           if isinstance(s, blocks.Struct) and s.name == element), None)
            if struct is None:  # an array of scalars: std430 packs them tight
                if item.kind == "buffer" and element in SCALAR_BYTES:
                    stride = variables[f"{member}[0]"]["GL_ARRAY_STRIDE"]
                    assert stride == SCALAR_BYTES[element], member
                    checked += 1
                continue
            found = uniforms if item.kind == "uniform" else variables
            for name, offset in _expected(struct.dtype, f"{member}[0].").items():
                assert found[name]["GL_OFFSET"] == offset, name
                checked += 1
            first = struct.dtype.names[0]
            if item.kind == "uniform":  # each element's members are listed one by one
                stride = (found[f"{member}[1].{first}"]["GL_OFFSET"]
                          - found[f"{member}[0].{first}"]["GL_OFFSET"])
            else:
                stride = found[f"{member}[0].{first}"]["GL_TOP_LEVEL_ARRAY_STRIDE"]
            assert stride == struct.dtype.itemsize, member
        assert checked > 0
    finally:
        prog.release()


@pytest.mark.parametrize("group", sorted(blocks.GROUPS))
def test_the_driver_places_every_member_where_the_dtype_does(ctx, group):
    check_group(ctx, group)


def test_glsl_that_drifted_from_its_dtype_is_caught(ctx, monkeypatch):
    text = blocks.GENERATED["blocks/frame.glsl"]
    drifted = text.replace("    vec3 camera_pos;\n    int floor_count;\n",
                           "    int floor_count;\n    vec3 camera_pos;\n")
    assert drifted != text
    monkeypatch.setitem(blocks.GENERATED, "blocks/frame.glsl", drifted)
    with pytest.raises(AssertionError, match="camera_pos|floor_count"):
        check_group(ctx, "blocks/frame.glsl")


def test_a_dtype_that_disagrees_with_the_layout_rules_is_refused():
    # An int after a vec3 sits in the vec3's last four bytes; a pad there moves it, which the
    # generated GLSL could not follow.
    moved = np.dtype([("position", "<f4", 3), ("_pad", "<f4"), ("count", "<i4")])
    with pytest.raises(AssertionError, match="count"):
        blocks.glsl_members(moved, "std140")
    with pytest.raises(AssertionError, match="bytes"):
        blocks.glsl_members(np.dtype([("position", "<f4", 3)]), "std140")  # not 16 bytes
    assert blocks.glsl_members(np.dtype([("position", "<f4", 3), ("count", "<i4")]),
                               "std140") == "    vec3 position;\n    int count;"


def test_no_shader_declares_a_block_itself():
    declaration = re.compile(r"^\s*layout\s*\([^)]*\)\s*(?:\w+\s+)*(uniform|buffer)\s+\w+\s*\{",
                             re.M)
    for path in sorted((ROOT / "shaders").iterdir()):
        assert not declaration.search(path.read_text()), path.name


def test_binding_points_are_distinct_and_within_any_gl_4_3():
    declared = [item for group in blocks.GROUPS.values() for item in group
                if isinstance(item, blocks.Block)]
    assert sorted(b.name for b in declared) == sorted(blocks.BINDINGS)
    for kind, table in (("uniform", blocks.UNIFORM_BINDINGS), ("buffer", blocks.STORAGE_BINDINGS)):
        assert all(b.kind == kind for b in declared if b.name in table)
        assert max(table.values()) < blocks.MIN_GL_BINDINGS[kind]
    # Within one shader (one generated group, and the frame's blocks that every group's shaders
    # may include beside it), no two blocks of a kind share a binding point.
    frame = blocks.GROUPS["blocks/frame.glsl"]
    for name, group in blocks.GROUPS.items():
        items = group + (frame if name != "blocks/frame.glsl" else [])
        for kind in ("uniform", "buffer"):
            points = [b.binding for b in items if isinstance(b, blocks.Block) and b.kind == kind]
            assert len(points) == len(set(points)), (name, kind)
