"""The elastic law of a grain (``geocontact.law.elastic``): the same file format and pair style as
the hysteretic law, Hertz on every path a DEM contact takes (docs/dem.md, "A like-for-like elastic
baseline")."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from geocontact.grain.hertz import hertz_coefficient
from geocontact.law import ContactArrays, LawParams, _core, load_params
from geocontact.law.elastic import elastic_law

ROOT = Path(__file__).resolve().parents[1]
LAWS = [ROOT / "examples" / name for name in ("params-reference.json",
                                              "params-reference-weak.json")]


@pytest.mark.parametrize("path", LAWS, ids=["reference", "weak"])
def test_the_elastic_law_is_hertz_where_the_plastic_law_yields_deeply(path):
    plastic = load_params(path)
    elastic = elastic_law(plastic)
    dy = plastic.yield_approach
    legs = [(0.0, 1e3), (1e3, 10.0), (10.0, 1e4), (1e4, 0.0), (0.0, 5e3)]
    approach = np.concatenate([np.linspace(a, b, 300) for a, b in legs]) * dy
    contacts = ContactArrays(elastic, 1, beyond_range="refuse")
    forces = np.array([contacts.step(np.array([d]))[0][0] for d in approach])
    hertz = hertz_coefficient(plastic.material) * approach**1.5
    assert np.allclose(forces, hertz, rtol=1e-12, atol=0.0)
    assert abs(contacts.dissipated_energy[0]) < 1e-12 * float(np.max(hertz * approach))
    assert np.allclose(contacts.contact_radius(),
                       np.sqrt(plastic.material.effective_radius * approach[-1]), rtol=1e-12)
    # the plastic law dissipates on the same path
    plastic_contacts = ContactArrays(plastic, 1, beyond_range="ignore")
    for d in approach:
        plastic_contacts.step(np.array([d]))
    assert plastic_contacts.dissipated_energy[0] > 0.0


def test_the_elastic_law_file_reads_alike_on_both_sides_and_says_what_it_is():
    plastic = load_params(LAWS[0])
    elastic = elastic_law(plastic)
    text = elastic.to_json()
    again = LawParams.from_dict(json.loads(text))
    cpp = _core.parse_params(text)
    assert again.yield_approach == cpp.yield_approach == 0.5 * plastic.material.radius
    assert again.material == plastic.material
    assert not again.cyclic.enabled and not cpp.cyclic.enabled
    assert again.calibrated_range["max_depth"] == 1.0
    assert "elastic" in again.label and again.provenance["plastic_law_label"] == plastic.label
