import os
import sys
from pathlib import Path

import pytest

from geocontact import preset

# the generators of shipped test data (golden vectors, bad law documents, illustrative laws) are
# scripts, not part of the package: the tests import them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
from geocontact.law import CyclicLaw, LawParams

# The LAMMPS plugin of this checkout, for in-process tests and their MPI subprocesses (which run
# in temporary folders).
os.environ.setdefault("GEOCONTACT_LAMMPS_PLUGIN", str(
    Path(__file__).resolve().parents[1] / "build" / "lammps-plugin" / "geocontactplugin.so"))

# A yield approach of the order of the reference case's; the law itself does not care where
# delta_y comes from (geocontact.grain.hertz supplies it in real parameter files).
YIELD_APPROACH = 2.0e-5


def make_params(**changes) -> LawParams:
    values = dict(
        material=preset("reference"),
        yield_approach=YIELD_APPROACH,
        elastic_plastic_exponent=1.25,
        fully_plastic_approach_ratio=20.0,
        fully_plastic_exponent=1.1,
        unloading_power=-0.03,
        reloading_power=-0.06,
        residual_limit=0.9,
        residual_power=0.35,
    )
    values.update(changes)
    return LawParams(**values)


@pytest.fixture(scope="module")
def reference_coarse():
    """The reference grain and a coarse FE mesh of it (contact zone 0.02 R, refined to 0.05 R):
    (material, mesh), the solver tests' set-up."""
    from geocontact.fem.mesh import build_mesh

    material = preset("reference")
    return material, build_mesh(material.radius, 0.02 * material.radius,
                                0.05 * material.radius, "coarse")


@pytest.fixture
def params() -> LawParams:
    return make_params()


@pytest.fixture
def cyclic_params() -> LawParams:
    return make_params(cyclic=CyclicLaw(enabled=True, residual_ratio_coefficient=0.3,
                                        residual_ratio_power=1.2, tolerance=0.01))


# The FE settings the tests whose subject is not the FE defaults name: the "yield" meshes and
# fixed load steps, the defaults before issue 36 (now "auto" and "adaptive", docs/fem.md
# "Defaults"), on which those tests were written and which are the cheapest above 10 Fy. The
# defaults themselves are tested in test_fe_defaults.py, test_fem_mesh_rule.py and
# test_fem_step_control.py.
YIELD_FIXED = {"mesh_rule": "yield", "step_control": "fixed"}


def assert_energy_balance(curve, tolerance: float = 0.01) -> None:
    """An FE run's energy balance at every step (docs/model.md §5: work of the force = stored
    elastic
    energy + plastic dissipation, within ``tolerance`` of the work; trapezoidal work on coarse
    steps) and a dissipation that never decreases."""
    import numpy as np

    work = curve["work_J"][1:]
    imbalance = work - curve["elastic_energy_J"][1:] - curve["plastic_dissipation_J"][1:]
    assert np.all(np.abs(imbalance) <= tolerance * work)
    assert np.all(np.diff(curve["plastic_dissipation_J"]) >= -1e-12 * work.max())


class Reached(Exception):
    """The command got past validation to the expensive work: the input was accepted."""


def _stop(*args, **kwargs):
    raise Reached


@pytest.fixture
def no_work(monkeypatch):
    """Stop a valid FE run at its mesh, a valid seismic run at its time integration, a sweep or
    calibration at its campaign, a DEM run at LAMMPS and a demo at its first step: a test of
    validation never does the work (tests/test_fuzz_cli.py, tests/test_bad_input.py)."""
    import geocontact.analyses.dem as dem
    import geocontact.analyses.dem_seismic as dem_seismic
    import geocontact.analyses.seismic.column as column
    import geocontact.analyses.sweeps as sweeps
    import geocontact.calibrate.campaign as calibration
    import geocontact.cli.demo as demo
    import geocontact.fem.campaign as fem_campaign
    import geocontact.fem.run as fem_run

    monkeypatch.setattr(fem_run, "history_mesh", _stop)
    monkeypatch.setattr(calibration, "run_campaign", _stop)
    monkeypatch.setattr(sweeps, "run_campaign", _stop)
    monkeypatch.setattr(column.Column, "run", _stop)
    monkeypatch.setattr(fem_campaign, "run_campaign", _stop)  # fit's FE master curve
    monkeypatch.setattr(dem, "run_lammps", _stop)
    monkeypatch.setattr(dem_seismic, "run_lammps", _stop)
    monkeypatch.setattr(demo, "_write_demo", _stop)


def fe_setting_reaching_the_run(monkeypatch, tmp_path, setting: str, flags: list[str]) -> list:
    """The value of the FE run's keyword ``setting`` that ``geocontact fem`` and ``cycles``
    pass on with ``flags`` (a short history on the coarse mesh; the run itself is captured, not
    made): one value per command. A setting not passed is the one run_history makes of it,
    FeSettings' default."""
    import geocontact.fem.run as fem_run
    from geocontact.cli import main
    from geocontact.fem.settings import FeSettings

    seen = []

    def capture(*args, **kwargs):
        seen.append(kwargs.get(setting, FeSettings.__dataclass_fields__[setting].default))
        raise Reached

    monkeypatch.setattr(fem_run, "run_history", capture)
    history = tmp_path / "h.toml"
    history.write_text("[history]\nforces = [0, 60, 0]\n")
    for command in ("fem", "cycles"):
        with pytest.raises(Reached):
            main([command, "--material", "reference", "--history", str(history), "--mesh",
                  "coarse", "--out", str(tmp_path / command), *flags])
    return seen
