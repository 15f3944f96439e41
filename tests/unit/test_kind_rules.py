"""The kinds' cross-field rules as their schemas state them for the page (x-rules, kept by
static/controls.js keepRules), against the validators that enforce them: over random
layers of each kind that has rules, the field set under its bound is refused, and the
field carried up to its bound (snapped to its slider step, as the page does) is accepted."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from fogbank.kinds import KINDS

pytestmark = pytest.mark.unit

RULED = [name for name, k in KINDS.items() if k.model.model_json_schema().get("x-rules")]


def test_the_kinds_with_cross_field_rules_state_them():
    assert sorted(RULED) == ["cosine", "particles"]


@pytest.mark.parametrize("name", RULED)
def test_each_stated_rule_is_the_validators(name):
    kind = KINDS[name]
    schema = kind.model.model_json_schema()
    rng = np.random.default_rng(37)
    for _ in range(40):
        layer = kind.sample(rng).model_dump(mode="json")
        for rule in schema["x-rules"]:
            b = rule["atLeast"]
            bound = (layer[b["field"]] if "field" in b
                     else sum(abs(item[b["sumAbs"][1]]) for item in layer[b["sumAbs"][0]]))
            prop = schema["properties"][rule["field"]]
            step = prop.get("step") or 1
            low = prop.get("minimum", -math.inf)
            under = bound - step
            if under >= low and under < bound:
                with pytest.raises(ValidationError):
                    kind.model.model_validate({**layer, rule["field"]: int(under) if prop.get("type") == "integer" else under})
            up = math.ceil(bound / step - 1e-9) * step
            up = int(round(up)) if prop.get("type") == "integer" else round(up, 10)
            if up <= prop.get("maximum", math.inf):
                kind.model.model_validate({**layer, rule["field"]: up})


def test_every_kind_requires_its_kind_and_carries_its_help():
    """A kind's own json_schema_extra (its rules) replaced LayerBase's: cosine and particles
    lost `kind` from their required fields (schemathesis then sent layers without one) and
    their help (the page showed none). Every kind keeps both."""
    for name, kind in KINDS.items():
        schema = kind.model.model_json_schema()
        assert (name, "kind" in schema.get("required", [])) == (name, True)
        assert (name, bool(schema.get("source")), bool(schema.get("summary"))) == (name, True, True)
