"""The shader loader: includes, #line mapping, and errors that name file and line."""

from __future__ import annotations

import moderngl
import numpy as np
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


def test_compile_error_names_file_and_line(renderer, tmp_path):
    (tmp_path / "ok.vert").write_text("void main() { gl_Position = vec4(0.0); }\n")
    (tmp_path / "lib.glsl").write_text("float f() {\n  return 1.0;\n}\nfloat g() { return undefined_thing; }\n")
    (tmp_path / "bad.frag").write_text('#include "lib.glsl"\nout vec4 c;\nvoid main() { c = vec4(f()); }\n')
    with pytest.raises(ShaderError) as exc:
        program(renderer.ctx, "ok.vert", "bad.frag", root=tmp_path)
    assert "lib.glsl:4" in str(exc.value)


def test_every_project_shader_compiles_for_every_preset_and_kind(renderer):
    from draws import ALL, random_layer
    from fogbank.kinds.packing import variant
    from fogbank.model.params import FogParams
    from fogbank.model.presets import preset_dict, presets
    from fogbank.render.rays import RAYS_PER_ROW
    looks = [FogParams.model_validate(preset_dict(name)) for name in presets()]
    rng = np.random.default_rng(4)
    looks += [FogParams(layers=[random_layer(k, rng)]) for k in ALL]
    for fog in looks:
        for scale in (1, 2, 4):
            assert isinstance(renderer.programs.fog(variant(fog), scale), moderngl.Program)
        prog = renderer.programs.get("passes/fullscreen.vert", "passes/rays.frag", variant(fog),
                                     RAYS_PER_ROW=RAYS_PER_ROW)
        assert isinstance(prog, moderngl.Program)


def test_a_uniform_the_program_does_not_declare_fails(renderer):
    """A misspelt uniform raises (it used to be skipped silently); one the compiler
    optimised away in this variant is skipped."""
    from fogbank.render.gl import set_uniform
    prog = renderer.sky_prog
    with pytest.raises(ShaderError, match="uSunDirection"):
        set_uniform(prog, "uSunDirection", np.zeros(3))
    set_uniform(prog, "uSunDir", np.array([0.0, 1.0, 0.0]))
    assert "uSunDir" in prog.extra["declared"]


def test_the_passes_read_only_what_earlier_passes_wrote():
    from fogbank.render.passes import FRAME_INPUTS, FRAME_PASSES
    available = set(FRAME_INPUTS)
    for p in FRAME_PASSES:
        assert set(p.reads) - available == set()
        available |= set(p.writes)
    assert [p.name for p in FRAME_PASSES] == ["shadow", "scene", "sky", "resolve", "fog", "fog_filter", "particles",
                                              "composite", "blur", "output"]
