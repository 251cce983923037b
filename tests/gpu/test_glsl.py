"""The shader preprocessor, as plain strings (no GL)."""

import pytest

from game.gpu import glsl
from game.gpu.glsl import ShaderSourceError, preprocess


def files(mapping):
    def read(name):
        return mapping[name]
    return read


def test_defines_go_right_after_version():
    out = preprocess("// header\n#version 430\nvoid main() {}", {"A": 1, "B": 2.5, "C": True})
    lines = out.split("\n")
    assert lines[:5] == ["// header", "#version 430", "#define A 1", "#define B 2.5",
                         "#define C 1"]


def test_float_define_keeps_a_decimal_point():
    assert "#define X 3.0" in preprocess("#version 430\n", {"X": 3.0})


def test_include_is_resolved_recursively():
    read = files({"a.glsl": '#include "b.glsl"\nfloat a;', "b.glsl": "float b;"})
    out = preprocess('#version 430\n#include "a.glsl"\nvoid main() {}', read=read)
    assert out.split("\n") == ["#version 430", "float b;", "float a;", "void main() {}"]


def test_missing_include_names_file_and_line():
    with pytest.raises(ShaderSourceError, match=r"main.frag:2: cannot include 'nope.glsl'"):
        preprocess('#version 430\n#include "nope.glsl"\n', read=files({}), name="main.frag")


def test_include_loop_hits_the_depth_limit():
    read = files({"a.glsl": '#include "b.glsl"', "b.glsl": '#include "a.glsl"'})
    with pytest.raises(ShaderSourceError, match="deeper than"):
        preprocess('#version 430\n#include "a.glsl"\n', read=read)


@pytest.mark.parametrize("value", [None, "text", float("nan"), float("inf"), [1]])
def test_bad_define_values_fail_loudly(value):
    with pytest.raises(ShaderSourceError):
        preprocess("#version 430\n", {"X": value})


def test_bad_define_name_fails():
    with pytest.raises(ShaderSourceError):
        preprocess("#version 430\n", {"1X": 1})


def test_no_version_line_fails():
    with pytest.raises(ShaderSourceError, match="no #version"):
        preprocess("void main() {}")


def test_every_shader_file_assembles():
    for path in glsl.SHADER_DIR.iterdir():
        if path.suffix in (".vert", ".frag", ".comp"):
            text = glsl.build(path.name, {"X": 1})
            assert "#include" not in text


def test_include_cannot_leave_the_shader_folder():
    with pytest.raises(ShaderSourceError):
        glsl.build("../pyproject.toml")
