"""The force bound from the measured contact (issue 37): a run stops where the contact radius it
measures passes the mesh's refined zone (``fem.mesh.CONTACT_RADIUS_LIMIT`` R), and the bound a
command checks before any work is the Hertz contact's, which no elastic-plastic contact is
smaller than. The estimate the bound used before (1.2 x Hertz's or a mean pressure of
2.5 sigma_c) is not an upper bound: on a soft grain the FE's contact passes it near R/2."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from conftest import YIELD_FIXED

from geocontact.cli import main
from geocontact.errors import ContactBeyondMeshError, ConvergenceError, InputError
from geocontact.fem.identity import _contact_beyond_mesh, load_result
from geocontact.fem.limits import check_resolved_force
from geocontact.fem.mesh import CONTACT_RADIUS_LIMIT
from geocontact.fem.result import CURVE_COLUMNS
from geocontact.fem.run import largest_contact_radius_estimate, run_history
from geocontact.grain.hertz import contact_radius, hertz_approach
from geocontact.grain.material import Material, preset

ROOT = Path(__file__).resolve().parent.parent
# E / sigma_c = 30, von Mises (beta = 0), no hardening: its plastic contact is wider than the
# estimate, which Hertz's dominates at this E / sigma_c
SOFT = {"youngs_modulus": 3e7, "poissons_ratio": 0.1, "compressive_yield_stress": 1e6,
        "friction_angle_deg": 0.0, "hardening_ratio": 0.0, "radius": 0.1}
FORCE = 40e3  # N: below the Hertz bound (50 kN), beyond the measured R/2 (about 14 kN)


def soft() -> Material:
    return Material(**SOFT)


def test_the_bound_is_where_the_hertz_contact_fills_the_refined_zone():
    material = preset("reference")
    radius = CONTACT_RADIUS_LIMIT * material.radius
    with pytest.raises(InputError, match=r"^--max-force: must be <= (\S+) N") as refused:
        check_resolved_force(material, 1e9, "--max-force")
    bound = float(str(refused.value).split("<= ")[1].split(" N")[0])
    a = float(contact_radius(material, hertz_approach(material, bound)))
    assert a == pytest.approx(radius, rel=1e-3)
    check_resolved_force(material, 0.999 * bound, "--max-force")  # admitted


def test_a_run_stops_where_its_contact_passes_the_refined_zone(tmp_path):
    checkpoint = tmp_path / "run.checkpoint.npz"
    with pytest.raises(ContactBeyondMeshError, match=r"^step (\d+): the contact radius") as err:
        run_history(soft(), [0.0, FORCE, 0.0], mesh="coarse", steps_per_segment=4,
                    out=tmp_path / "run", checkpoint=checkpoint, **YIELD_FIXED)
    assert isinstance(err.value, ConvergenceError)  # a campaign treats it as a failed run
    message = err.value.args[0]
    assert "passed 0.5 R" in message
    measured = float(message.split("the contact radius ")[1].split(" m")[0])
    force = float(message.split("at F = ")[1].split(" N")[0])
    assert measured > CONTACT_RADIUS_LIMIT * SOFT["radius"]
    # the estimate the bound used before is below the contact the FE measures there
    check_resolved_force(soft(), FORCE, "history.forces")  # admitted now: Hertz's a < R/2
    assert largest_contact_radius_estimate(soft(), force) < measured
    assert not (tmp_path / "run").exists()  # no result that looks complete
    with np.load(checkpoint, allow_pickle=False) as saved:
        rows = np.asarray(saved["rows"])
    step = int(err.value.args[0].split()[1].rstrip(":"))
    assert len(rows) == step  # the initial state and the steps before the one that passed
    radius = rows[:, CURVE_COLUMNS.index("contact_radius_m")]
    assert 0.3 * SOFT["radius"] < np.max(radius) <= CONTACT_RADIUS_LIMIT * SOFT["radius"]


def test_the_cli_says_it_in_one_line(tmp_path, capsys):
    material = tmp_path / "soft.toml"
    material.write_text("[material]\n" + "".join(
        f"{k} = {v!r}\n" for k, v in SOFT.items() if k != "radius")
        + f"\n[geometry]\nradius = {SOFT['radius']!r}\n")
    history = tmp_path / "h.toml"
    history.write_text(f"[history]\nforces = [0, {FORCE!r}, 0]\n")
    assert main(["fem", "--material", str(material), "--history", str(history), "--mesh",
                 "coarse", "--steps", "4", "--mesh-rule", "yield", "--step-control", "fixed",
                 "--out", str(tmp_path / "run")]) == 1
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("error: step ") and "passed 0.5 R" in last
    assert "ask for a lower force" in last


def test_a_run_whose_contact_outgrew_the_mesh_is_not_reused():
    """A finished run of older code that went on past R/2 is not reused (``equivalent_run``);
    none of the committed runs did (the largest, a probe of the campaign of record, 0.467 R)."""
    run = load_result(ROOT / "datasets/fe-runs/universal-record/553849a6c01f5e289cbb")
    assert not _contact_beyond_mesh(run)
    grain = run.summary["inputs"]["material"]["radius"]
    radius = np.asarray(run.curve["contact_radius_m"], dtype=float)
    assert 0.46 * grain < np.max(radius) <= CONTACT_RADIUS_LIMIT * grain
    grown = dict(run.curve, contact_radius_m=radius * 1.1)
    assert _contact_beyond_mesh(dataclasses.replace(run, curve=grown))


def test_a_campaign_reports_the_run_in_one_line_without_the_workers_traceback(tmp_path,
                                                                             capfd):
    """Through Dask's local cluster (two jobs, two workers): the soft grain past R/2 fails in
    one line naming it, the other run finishes, and the workers print no traceback of theirs
    (their "Compute Failed" log is silenced; the campaign's own line says what failed)."""
    from geocontact.fem.campaign import CampaignError, FemJob, run_campaign

    jobs = [FemJob(soft(), (0.0, FORCE, 0.0), mesh="coarse", steps_per_segment=4, **YIELD_FIXED),
            FemJob(soft(), (0.0, 100.0, 0.0), mesh="coarse", steps_per_segment=4, **YIELD_FIXED)]
    with pytest.raises(CampaignError):
        run_campaign(jobs, tmp_path / "cache", workers=2, progress=True, progress_every=None)
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Compute Failed" not in err, err
    (failed,) = [line for line in err.splitlines() if "FAILED" in line]
    assert "ContactBeyondMeshError" in failed and "passed 0.5 R" in failed
    assert (tmp_path / "cache" / jobs[1].key() / "summary.json").is_file()
