"""The shader loader: includes, #line mapping, and errors that name file and line."""

from __future__ import annotations

import moderngl
import pytest

from fogbank.render.glsl import ShaderError, load, program


def test_includes_once_with_line_directives(tmp_path):
    (tmp_path / "a.glsl").write_text('#include "b.glsl"\nfloat a() { return b(); }\n')
    (tmp_path / "b.glsl").write_text("float b() { return 1.0; }\n")
    (tmp_path / "main.glsl").write_text('#include "a.glsl"\n#include "b.glsl"\nvoid main() {}\n')
    src = load("main.glsl", {"X": 3}, root=tmp_path)
    assert src.text.count("float b()") == 1
    assert src.files == ["main.glsl", "a.glsl", "b.glsl"]
    assert src.text.startswith("#version 330 core\n#define X 3\n#line 1 0\n")
    assert "#line 2 1" in src.text   # back in a.glsl after its include


def test_missing_include_and_cycle(tmp_path):
    (tmp_path / "m.glsl").write_text('#include "nope.glsl"\n')
    with pytest.raises(ShaderError, match="m.glsl: cannot include 'nope.glsl'"):
        load("m.glsl", root=tmp_path)
    (tmp_path / "x.glsl").write_text('#include "y.glsl"\n')
    (tmp_path / "y.glsl").write_text('#include "x.glsl"\n')
    with pytest.raises(ShaderError, match="cycle"):
        load("x.glsl", root=tmp_path)
    with pytest.raises(ShaderError):
        load("../etc/passwd", root=tmp_path)


def test_compile_error_names_file_and_line(renderer, tmp_path, monkeypatch):
    import fogbank.render.glsl as sh
    (tmp_path / "ok.vert").write_text("void main() { gl_Position = vec4(0.0); }\n")
    (tmp_path / "lib.glsl").write_text("float f() {\n  return 1.0;\n}\nfloat g() { return undefined_thing; }\n")
    (tmp_path / "bad.frag").write_text('#include "lib.glsl"\nout vec4 c;\nvoid main() { c = vec4(f()); }\n')
    monkeypatch.setattr(sh, "SHADER_DIR", tmp_path)
    real_load = sh.load
    monkeypatch.setattr(sh, "load", lambda name, defines=None, generated=None: real_load(name, defines, root=tmp_path, generated=generated))
    with pytest.raises(ShaderError) as exc:
        program(renderer.ctx, "ok.vert", "bad.frag")
    assert "lib.glsl:4" in str(exc.value)


def test_every_project_shader_compiles(renderer):
    from fogbank.model.params import FogParams
    from fogbank.model.presets import preset_dict, presets
    for name in presets():
        fog = FogParams.model_validate(preset_dict(name))
        for scale in (1, 2, 4):
            assert isinstance(renderer.fog_program(fog, scale), moderngl.Program)
        assert isinstance(renderer.rays_program(fog), moderngl.Program)
