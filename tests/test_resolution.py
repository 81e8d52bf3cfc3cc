"""``geocontact.fem.roundoff``: values below a run's resolution are round-off, reported as 0."""

import pytest

from geocontact.fem.roundoff import (
    RELATIVE,
    Resolution,
    clean_fe_cycles,
    fe_resolutions,
    fe_summary_resolutions,
    seismic_energy,
)


def test_round_off_of_either_sign_is_zero_and_says_so():
    r = Resolution(1e-15, "J", "1e-12 x something")
    assert r.clean(-5.8e-25) == 0.0 and r.clean(2e-16) == 0.0 and r.clean(None) is None
    assert r.clean(3e-15) == 3e-15 and r.clean(-3e-15) == -3e-15
    assert r.format(-2e-16) == "0 J (below the resolution 1e-15 J)"
    assert r.format(0.0123, ".3g") == "0.0123 J"
    assert r.note() == ("Values below the run's resolution (1e-15 J, 1e-12 x something) are "
                        "round-off and shown as 0.")
    assert Resolution.from_dict(r.to_dict()) == r


def test_fe_resolutions_from_the_run_and_from_an_older_summary():
    cycles = [{"max_force_N": 100.0, "max_approach_m": 2e-5, "residual_approach_m": -4e-23,
               "plastic_work_J": -5.8e-25, "loop_work_J": 1e-20,
               "residual_elastic_energy_J": 3e-6, "steps": [0, 8]},
              {"max_force_N": 50.0, "max_approach_m": 1e-5, "residual_approach_m": None,
               "plastic_work_J": 1e-9, "loop_work_J": 2e-9, "residual_elastic_energy_J": 0.0,
               "steps": [8, 16]}]
    recorded = fe_resolutions(100.0, 2e-5)
    assert recorded["energy"].value == pytest.approx(RELATIVE * 100.0 * 2e-5)
    assert recorded["approach"].value == pytest.approx(RELATIVE * 2e-5)
    # a summary without a "resolution" entry gets the same definition from its cycles
    assert fe_summary_resolutions({"cycles": cycles}) == recorded
    first, second = clean_fe_cycles(cycles, recorded)
    assert (first["plastic_work_J"], first["loop_work_J"], first["residual_approach_m"]) == (
        0.0, 0.0, 0.0)
    assert first["residual_elastic_energy_J"] == 3e-6 and first["steps"] == [0, 8]
    assert second == cycles[1]  # physics untouched, None kept


def test_seismic_resolution_is_relative_to_the_largest_work():
    r = seismic_energy(6.6e-4, 5.0e-3, -8.1e-3)
    assert r.value == pytest.approx(RELATIVE * 8.1e-3)
    assert seismic_energy().value == 0.0
