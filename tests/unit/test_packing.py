"""The packing and the generated GLSL, held to the registry's declarations.

- Every field of every kind changes the packed GPU data (the uniform block, the particle
  texture or the variant key that picks the program), or the kind declares it CPU-only.
- Every kind's slots fit the per-layer budget, and a layout over it fails at import.
- The generated GLSL depends only on the variant key: no text a user sends reaches it.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from pydantic import ValidationError

from draws import ALL, random_layer
from fogbank.kinds import KINDS
from fogbank.kinds.kind import LAYER_VEC4, Layout, SlotError
from fogbank.kinds.packing import carve_code, density_code, layer_code, variant
from fogbank.model.fields import MAX_LAYERS
from fogbank.model.params import FogParams
from fogbank.render.frame import Simulations, plan_fog

LOOK = {"time": 2.5, "wind": {"speed": 3.0, "direction": 40.0}}


def packed(layer):
    """Everything a layer sends to the GPU: its uniform block, the particle rows (positions
    and strengths, radii) and the variant key, packed relative to an eye away from the
    origin, through the renderer's own preparation (render/frame.py: simulation, cache and
    packing)."""
    fog = FogParams.model_validate({**LOOK, "layers": [layer.model_dump()]})
    plan = plan_fog(fog, fog.time, (3.0, 7.0, -2.0), Simulations())
    return plan.packed.data, plan.packed.particles, plan.key, plan.packed.radii


def differs(a, b) -> bool:
    return a[2] != b[2] or any(not np.array_equal(x, y) for x, y in ((a[0], b[0]), (a[1], b[1]), (a[3], b[3])))


def leaves(value, path=()):
    """(path, value) of every leaf of a dumped model (numbers, booleans, strings)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from leaves(v, path + (k,))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from leaves(v, path + (i,))
    else:
        yield path, value


def replaced(d, path, v):
    if not path:
        return v
    d = list(d) if isinstance(d, (list, tuple)) else dict(d)
    d[path[0]] = replaced(d[path[0]], path[1:], v)
    return d


def candidates(v, literals):
    if isinstance(v, bool):
        return [not v]
    if isinstance(v, str):
        return [x for x in literals if x != v]
    if isinstance(v, int):
        return [v + 1, v - 1, v * 2, max(1, v // 2)]
    return [v * 1.37 + 0.113, v * 0.61 - 0.07, v + 1.0, v - 1.0, 0.5 * v, v + 0.01]


def literal_values(model) -> set:
    out = set()
    for f in model.model_fields.values():
        args = getattr(f.annotation, "__args__", ())
        if getattr(f.annotation, "__origin__", None) is not None and all(isinstance(a, str) for a in args):
            out |= set(args)
    return out


@pytest.mark.parametrize("name", ALL)
def test_every_field_reaches_the_gpu_or_is_declared_cpu_only(name):
    """Each leaf (every component of a vector, every term and coefficient) is perturbed
    within the schema over 8 draws; each must change the packed data in some draw. A field
    declared CPU-only must change it in none."""
    kind = KINDS[name]
    rng = np.random.default_rng(ALL.index(name))
    literals = literal_values(kind.model)
    reached, tried, cpu_changed = set(), set(), set()
    for _ in range(8):
        layer = random_layer(name, rng)
        base = packed(layer)
        dumped = layer.model_dump(mode="json")
        for path, v in leaves(dumped):
            if path[0] in ("kind", "enabled"):
                continue
            tried.add(path)
            for c in candidates(v, literals):
                try:
                    other = kind.model.model_validate(replaced(dumped, path, c))
                except ValidationError:
                    continue
                if differs(packed(other), base):
                    reached.add(path)
                    if path[0] in kind.cpu_only:
                        cpu_changed.add(path)
                    break
    missed = {p for p in tried - reached if p[0] not in kind.cpu_only}
    assert missed == set()
    assert cpu_changed == set()   # CPU-only really is: it never changes what the GPU gets
    assert set(kind.cpu_only) <= set(kind.model.model_fields)


@pytest.mark.parametrize("name", ALL)
def test_every_slot_is_read_by_the_generated_glsl(name):
    """A slot that is packed but that no GLSL reads is a field that does nothing."""
    kind = KINDS[name]
    rng = np.random.default_rng(50 + ALL.index(name))
    refs = kind.layout.refs(0)
    code = ""
    for _ in range(20):   # every variant the draws reach (term counts, modes)
        v = kind.variant(random_layer(name, rng))
        code += kind.code(refs, v) + (kind.density_code(refs, v) if kind.density_code else "")
    def read(s) -> bool:
        """The slot's own GLSL expression (uLayer[i].yz, not a longer swizzle of its
        vec4) appears; for an array, its first element or its first vec4."""
        forms = [s.ref(0)] if s.count == 1 else [s.ref(0, 0)] + ([refs.group(s.name, 0)] if s.size == 1 else [])
        return any(re.search(re.escape(f) + r"(?![\w\[])", code) for f in forms)

    unread = [s.name for s in kind.layout.slots.values() if not read(s)]
    assert unread == []


def test_every_slot_fits_the_budget_and_an_overfull_layout_fails():
    for kind in KINDS.values():
        assert kind.layout.vec4s <= LAYER_VEC4
    # 192 of the 256 fragment uniform vec4s GL 3.3 guarantees
    assert MAX_LAYERS * LAYER_VEC4 <= 192
    with pytest.raises(SlotError, match="budget"):
        Layout("too-big", ("terms", 4, LAYER_VEC4), ("more", 1))
    with pytest.raises(SlotError, match="size"):
        Layout("bad", ("odd", 3, 2))
    with pytest.raises(SlotError, match="reserved"):   # Refs.base would shadow a slot "base"
        Layout("bad", ("base", 1))


def test_a_pack_that_misses_a_slot_fails():
    layout = Layout("demo", ("a", 1), ("b", 3))
    block = np.zeros((LAYER_VEC4, 4))
    with pytest.raises(SlotError, match="slots are"):
        layout.write(block, {"a": 1.0})
    layout.write(block, {"a": 1.0, "b": (2.0, 3.0, 4.0)})
    assert block[0].tolist() == [1.0, 2.0, 3.0, 4.0]


def test_generated_glsl_comes_only_from_the_variant_key():
    rng = np.random.default_rng(3)
    # the models' literals, and the server's own flag of a carving body (kinds/box.py)
    allowed = set().union(*(literal_values(k.model) for k in KINDS.values())) | {"carve"}
    for _ in range(200):
        names = [str(rng.choice(ALL)) for _ in range(int(rng.integers(0, 16)))]
        a = FogParams(layers=[random_layer(n, rng) for n in names])
        for kind, v in variant(a):
            assert kind in KINDS
            for x in v:
                assert (type(x) is int and 0 <= x <= 8) or x in allowed
        code = layer_code(variant(a)) + carve_code(variant(a)) + density_code(variant(a))
        assert re.fullmatch(r"[\w\s.,;:?()\[\]{}<>=+\-*/%#&|!]*", code) is not None


@pytest.mark.parametrize("patch", [
    {"fog_color": "#abc; } void main() {"},
    {"layers": [{"kind": "sphere; discard;"}]},
    {"effects": {"blur": "single\n#define X"}},
    {"noise": {"size": "64; }"}},
])
def test_strings_never_pass_into_the_look(patch):
    with pytest.raises(ValidationError):
        FogParams.model_validate(patch)


def test_layers_of_one_kind_are_one_loop_over_their_slots_wherever_they_sit():
    """layer_code writes each repeated kind's code once, in a loop over the slots that
    loop_tables lists; a kind that appears once, or whose code is tiny (Kind.loop False:
    height), stays inline at its own slot."""
    from fogbank.kinds.packing import layer_code, loop_tables
    key = (("box", ()), ("potential", ()), ("box", ()), ("cosine", (2,)), ("potential", ()),
           ("cosine", (3,)), ("box", ()), ("height", ()), ("height", ()))
    code = layer_code(key)
    assert code.count("boxOpticalDepth(") == 1
    assert code.count("potentialOpticalDepth(") == 1
    assert code.count("cosineTermOpticalDepth(") == 2 + 3   # two variants, each inline once
    assert code.count("heightOpticalDepth(") == 2            # tiny: inline, each at its slot
    assert code.count("for (int i = ") == 2
    slots, counts = loop_tables(key)
    assert list(slots[:5]) == [0, 2, 6, 1, 4]    # the boxes' slots, then the potentials'
    assert list(counts[:3]) == [3, 2, 0]
    assert "uLayer[60]" in code and "uLayer[96]" in code and "uLayer[84]" in code   # slots 5, 8, 7
