"""The shader loader: includes, #line mapping, and errors that name file and line."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from fogbank.kinds.packing import layer_code, variant
from fogbank.model import presets as P
from fogbank.model.params import StillParams
from fogbank.render.glsl import ShaderError, load, program
from fogbank.render.probes import fog_only
from fogbank.tools.bench import _reference


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
        for sun in (False, True):
            assert isinstance(renderer.programs.fog(variant(fog), sun=sun), moderngl.Program)
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
    assert [p.name for p in FRAME_PASSES] == ["shadow", "scene", "sky", "resolve", "light", "fog", "fog_filter", "particles",
                                              "composite", "blur", "output"]


def test_interleaved_layers_of_repeated_kinds_each_read_their_own_slot(renderer):
    """The loops over layers of one kind (kinds/packing.py layer_code, loop_tables) against
    the float64 closed forms. Boxes, potentials and cosines interleaved with others, each with its own parameters
    (a loop reading the wrong slot would move or swap a layer), give the fog texels'
    transmittance of the float64 reference; the program holds each kind's code once."""
    layers = [
        {"kind": "box", "center": (-20.0, 10.0, 20.0), "half_size": (25.0, 10.0, 15.0), "density": 0.04},
        {"kind": "potential", "center": (10.0, 5.0, -30.0), "strength": 1.0, "c": 20.0, "e": 1.0},
        {"kind": "height", "density": 0.01, "falloff": 0.05, "base": 10.0},
        {"kind": "cosine", "density": 0.01, "c0": 1.0, "scale": 15.0,
         "terms": [{"amp": 0.6, "k": (1.0, 0.0, 0.3), "phase": 0.2}]},
        {"kind": "box", "center": (30.0, 5.0, -40.0), "half_size": (40.0, 8.0, 20.0), "yaw": 30.0,
         "density": 0.02},
        {"kind": "ellipsoid", "center": (0.0, 6.0, 0.0), "radii": (30.0, 8.0, 15.0), "density": 0.06},
        {"kind": "cosine", "density": 0.02, "c0": 1.0, "scale": 40.0,
         "terms": [{"amp": 0.9, "k": (0.0, 1.0, 1.0), "phase": 1.0}]},
        {"kind": "potential", "center": (-40.0, 2.0, -10.0), "strength": 2.0, "c": 30.0, "e": 1.5},
    ]
    still = StillParams.model_validate({**P.preset_dict("default"), "layers": layers, "width": 160,
                                        "height": 90, "time": 2.0,
                                        "effects": {**P.preset_dict("default")["effects"], "fog_scale": 1}})
    code = layer_code(variant(still))
    assert [code.count(f) for f in ("boxOpticalDepth(", "potentialOpticalDepth(", "cosineTermOpticalDepth(")] \
        == [1, 1, 1]
    _, T, invd, view = fog_only(renderer, still)
    ref = _reference(still, invd.astype(np.float64), view)
    assert float(np.abs(T - ref).max()) < 2e-3
    # in optical depth, where the fog lets light through
    seen = ref > 1e-3
    tau, tau_ref = -np.log(np.maximum(T, 1e-30))[seen], -np.log(ref[seen])
    assert float(np.abs(tau - tau_ref).max()) < 1e-3   # optical depths up to ~7 here
    # and every repeated layer counts: without any one of them, the optical depth is off by
    # a hundred times that somewhere
    for k in (0, 1, 3, 4, 6, 7):
        fewer = still.model_copy(update={"layers": still.layers[:k] + still.layers[k + 1:]})
        tau_fewer = -np.log(_reference(fewer, invd.astype(np.float64), view)[seen])
        assert float(np.abs(tau - tau_fewer).max()) > 0.1
