"""The design of record of the universal law (issue 37): coverage and determinism of the point
list, the level rule by contact size, the FE settings, the dataset row and the interpolation on a
tiny synthetic set, the pilot's achieved levels, and one-line errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.identity import recorded_kernels
from geocontact.fem.run import largest_contact_radius_estimate
from geocontact.fem.settings import DEFAULT_STEP_CONTROL, FeSettings
from geocontact.grain.hertz import incipient_yield
from geocontact.universal import record, record_dataset, record_law
from geocontact.universal.design import design_points as v1_points

ROOT = Path(__file__).resolve().parents[1]
PILOT = ROOT / "datasets" / "universal" / "record-pilot"


# --- the design ------------------------------------------------------------------------------
def test_design_spans_the_widened_box_and_is_deterministic():
    points = record.design_points(64)
    assert points == record.design_points(64)  # the same list every time
    assert [p.index for p in points] == list(range(64))
    coords = np.array([p.coordinates for p in points])
    low = np.array([a[1] for a in record.AXES])
    high = np.array([a[2] for a in record.AXES])
    assert np.allclose(coords[0], (low + high) / 2)  # the centre first
    # the half fraction: the first 9 points reach both ends of every axis
    assert np.allclose(coords[:9].min(axis=0), low) and np.allclose(coords[:9].max(axis=0), high)
    assert np.all(coords >= low - 1e-12) and np.all(coords <= high + 1e-12)
    # the box: E/sigma_c 30 .. 1e5, beta 0-60, nu 0.1-0.4, m 0-0.3
    assert math.isclose(10 ** low[3], 30.0) and math.isclose(10 ** high[3], 1e5)
    assert tuple(low[:3]) == (0.0, 0.1, 0.0) and tuple(high[:3]) == (60.0, 0.4, 0.3)
    # a 64-point campaign fills each axis: no gap wider than a sixth of its range
    for k in range(4):
        u = np.sort(record.unit(coords)[:, k])
        assert np.max(np.diff(u)) < 1.0 / 6.0
    # extending continues the same list
    assert record.design_points(70)[:64] == points


def test_today_design_is_unchanged():
    """v1 keeps its box and its sequence (the shipped dataset's indices)."""
    first = v1_points(3)
    assert first[0].coordinates == (27.5, 0.25, 0.15, 3.0)
    assert first[1].coordinates == (0.0, 0.15, 0.0, 2.0)


def test_fe_settings_of_record_and_pilot_overrides():
    s = record.fe_settings()
    assert (s.mesh, s.kinematics, s.kernels) == ("default", "finite", "compiled")
    # the record runs the FE's verified default mesh rule (issue 36), whatever it becomes, and
    # the envelope control (the default control with the reload measured against itself)
    defaults = FeSettings()
    assert s.mesh_rule == defaults.mesh_rule == "auto"
    assert s.step_control == record.RECORD_STEP_CONTROL == "envelope"
    assert DEFAULT_STEP_CONTROL == "dissipation"
    # its base (a ramp, no reload) is the default control's run: the same key
    point = record.design_points(1)[0]
    assert record.base_job(point, s, 1.0).key() == record.base_job(
        point, record.fe_settings(step_control=DEFAULT_STEP_CONTROL), 1.0).key()
    # the pilot's settings are the ones its committed provenance records
    pilot = record.fe_settings(**record.PILOT_FE)
    assert (pilot.mesh, pilot.kinematics, pilot.kernels) == ("coarse", "finite", "compiled")
    committed = json.loads((PILOT / "provenance.json").read_text())["fe"]
    assert (pilot.mesh, pilot.mesh_rule) == (committed["mesh"], committed["mesh_rule"])
    assert pilot.step_control == committed.get("step_control", "fixed")  # before the choice
    job = record.job(record.design_points(1)[0].material(), (0.0, 1.0, 0.0), s, "x", 2.0)
    assert job.settings() == record.fe_settings().__class__(**{**s.as_dict(), "mesh_force": 2.0})
    # the compiled kernels are the node contact's default: not in the inputs, but the record
    # names their code, so it reads as a compiled run
    recorded = job.identity().to_dict()
    assert "kernels" not in recorded["inputs"] and "compiled_code" in recorded
    assert recorded_kernels(recorded) == "compiled"


def test_validity_force_is_the_fe_bound():
    for point in record.design_points(17):
        m = point.material()
        f = record.validity_force(m)
        assert largest_contact_radius_estimate(m, f) <= 0.5 * m.radius
        assert largest_contact_radius_estimate(m, f * (1 + 1e-6)) > 0.5 * m.radius * (1 - 1e-6)
        assert f > 2 * incipient_yield(m).force  # above the lowest level


# --- the level rule --------------------------------------------------------------------------
def _plastic_curve(material, pressure, top):
    """A probe-like loading whose contact carries a constant mean pressure (a = sqrt(F/pi p))."""
    force = np.geomspace(0.3 * incipient_yield(material).force, top, 40)
    return force, np.sqrt(force / (math.pi * pressure))


def test_level_rule_places_the_levels_by_contact_radius():
    m = record.design_points(1)[0].material()
    p = 5.0 * m.compressive_yield_stress
    force, radius = _plastic_curve(m, p, math.pi * p * (0.35 * m.radius) ** 2)
    assert record.next_probe_force(m, force, radius) is None  # beyond 0.3 R: no more probes
    levels = record.level_forces(m, force, radius)
    targets = np.array(levels["target_contact_over_radius"])
    assert math.isclose(targets[-1], record.TOP_CONTACT_OVER_RADIUS)
    assert np.allclose(np.diff(np.log(targets)), np.log(targets[1] / targets[0]))
    assert math.isclose(levels["forces_N"][0], 2.0 * incipient_yield(m).force)
    # above the lowest level, each force gives its target radius on this curve
    a = np.sqrt(np.array(levels["forces_N"][1:]) / (math.pi * p)) / m.radius
    assert np.allclose(a, targets[1:], rtol=1e-6)
    assert levels["top"] == "0.3 R"


def test_level_rule_stops_at_what_the_probe_reached():
    m = record.design_points(1)[0].material()
    p = 5.0 * m.compressive_yield_stress
    top = math.pi * p * (0.2 * m.radius) ** 2  # the probe reaches a = 0.2 R only
    force, radius = _plastic_curve(m, p, top)
    levels = record.level_forces(m, force, radius)
    assert math.isclose(levels["target_contact_over_radius"][-1], 0.2, rel_tol=1e-9)
    assert "the largest contact the FE reached" in levels["top"]
    # the next probe aims at 1.1 x 0.3 R at the mean pressure reached
    nxt = record.next_probe_force(m, force, radius)
    assert math.isclose(nxt, math.pi * p * (0.33 * m.radius) ** 2, rel_tol=1e-9)


def test_levels_are_branches_of_the_base_at_its_nearest_steps():
    """The base run goes to the force carrying 1.1 x the top target on the probes' a(F); each
    level and the repeated history follow it to its recorded loading step nearest their force
    (in log F), on its mesh; the rule's forces are kept beside."""
    point = record.design_points(1)[0]
    m = point.material()
    p = 5.0 * m.compressive_yield_stress
    force, radius = _plastic_curve(m, p, math.pi * p * (0.35 * m.radius) ** 2)
    levels = record.level_forces(m, force, radius)
    rule = list(levels["forces_N"])
    settings = record.fe_settings(mesh="coarse")
    assert settings.step_rule == "decade"
    assert record.probe_settings(settings).mesh == record.PROBE_MESH
    assert not record.probe_job(point, settings).snapshots  # probes are not followed
    aim = record.PROBE_AIM * record.TOP_CONTACT_OVER_RADIUS * m.radius
    assert math.isclose(record.base_force(m, force, radius), math.pi * p * aim ** 2,
                        rel_tol=1e-6)  # within the probe's reach: read off its a(F)
    short = force < math.pi * p * (0.2 * m.radius) ** 2  # a probe that stops at 0.2 R
    assert math.isclose(record.base_force(m, force[short], radius[short]),
                        math.pi * p * aim ** 2, rel_tol=1e-9)  # at its last mean pressure
    base = record.base_job(point, settings, float(force[-1]))
    assert base.snapshots and base.follows is None
    curve = {"force_N": np.concatenate([[0.0], force])}  # step k at force[k - 1]
    runs, cyclic = record.point_jobs(point, settings, levels, base, curve)
    assert levels["rule_forces_N"] == rule and levels["base_key"] == base.key()
    assert len(runs) == record.LEVELS and len(levels["base_steps"]) == record.LEVELS
    for run, step, peak, wanted in zip(runs, levels["base_steps"], levels["forces_N"], rule,
                                       strict=True):
        assert run.follows == (base.forces, step) and peak == curve["force_N"][step]
        assert run.forces == (0.0, peak, 0.0, peak, 0.0)
        # the nearest step: no other recorded force is closer in log F
        assert abs(math.log(peak / wanted)) == min(abs(math.log(f / wanted)) for f in force)
        assert run.identity().mesh_force == base.identity().mesh_force  # the probe's mesh
    half = 0.5 * rule[-1]
    assert cyclic.follows[0] == base.forces and cyclic.forces[1] == curve["force_N"][
        cyclic.follows[1]]
    assert abs(math.log(cyclic.forces[1] / half)) <= math.log(force[1] / force[0]) / 2 + 1e-12
    assert len(cyclic.forces) == 21  # ten cycles 0 -> F -> 0
    # with the "envelope" control the levels (two cycles) and the repeated history reload and
    # keep it; the base never reloads: the default control's run, key and snapshots
    envelope = record.fe_settings(mesh="coarse", step_control="envelope")
    runs_e, cyclic_e = record.point_jobs(point, envelope, levels, base, curve)
    for branch in (*runs_e, cyclic_e):
        assert branch.identity().settings.step_control == "envelope"
        assert branch.identity().base().key() == base.key()
    assert record.base_job(point, envelope, float(force[-1])).key() == base.key()
    assert base.identity().settings.step_control == DEFAULT_STEP_CONTROL
    # steps too far apart for the levels: one line
    with pytest.raises(InputError, match="too far apart"):
        record.level_steps([1.0, 1.01], {"force_N": np.array([0.0, 1.0, 10.0])})


def test_top_spans_a_doubling_where_yield_is_late():
    """E/sigma_c = 30, beta = 60: first yield at a/R ~ 0.16; the top is twice the lowest level's
    contact radius, below 0.45 R."""
    from geocontact.grain.material import Material

    m = Material(youngs_modulus=1e10, poissons_ratio=0.4, compressive_yield_stress=1e10 / 30,
                 friction_angle_deg=60.0, hardening_ratio=0.0, radius=0.1)
    p = 3.0 * m.compressive_yield_stress
    force = np.geomspace(0.5 * incipient_yield(m).force, math.pi * p * (0.5 * m.radius) ** 2, 40)
    radius = np.maximum(np.sqrt(force / (math.pi * p)), incipient_yield(m).contact_radius)
    low = record.lowest_contact(m, force, radius)[1]
    assert low > 0.15 * m.radius
    top = record.top_target(m, force, radius)
    assert math.isclose(top, min(2.0 * low, 0.45 * m.radius))


def test_level_rule_refuses_a_probe_without_contact_growth():
    m = record.design_points(1)[0].material()
    fy = incipient_yield(m).force
    with pytest.raises(InputError, match="record levels: the probe spans"):
        record.level_forces(m, [0.5 * fy, 1.5 * fy], [1e-3, 1.1e-3])  # short of 2 Fy
    # a probe that starts above 2 Fy: the lowest contact is Hertz's, and 3-4 Fy add too little
    with pytest.raises(InputError, match="record levels: the probe's contact grows only"):
        record.level_forces(m, [3 * fy, 4 * fy], [2.0e-4, 2.1e-4])
    with pytest.raises(InputError, match="fewer than 2"):
        record.level_forces(m, [3 * fy], [1e-3])


# --- the dataset row, the cycles and the interpolation ---------------------------------------
def _synthetic_rows(n: int, coefficients: np.ndarray) -> list[dict]:
    """Rows whose every law column is linear in the unit coordinates (an RBF with a degree-1
    polynomial reproduces a linear function exactly, anywhere)."""
    cols = record_dataset.columns()
    law = record_dataset.law_columns()
    rows = []
    for point in record.design_points(n):
        u = record.unit(point.coordinates)
        row = {c: None for c in cols}
        row["index"] = point.index
        row.update(zip(record.AXIS_NAMES, point.coordinates, strict=True))
        for j, c in enumerate(law):
            row[c] = float(coefficients[j, 0] + coefficients[j, 1:] @ u)
        rows.append(row)
    return rows


def test_rows_round_trip_and_interpolate_exactly_on_a_linear_set(tmp_path):
    law = record_dataset.law_columns()
    rng = np.random.default_rng(3)
    coefficients = rng.uniform(-1.0, 1.0, (len(law), 5))
    rows = _synthetic_rows(12, coefficients)
    (tmp_path / "points.csv").write_text(record_dataset.format_rows(rows))
    data = record_dataset.read_points(tmp_path)
    assert data["index"].tolist() == list(range(12))
    assert np.isnan(data["second_increment_0"]).all()  # empty cells read back as empty
    surfaces, _ = record_law.read_surfaces(tmp_path)
    assert surfaces.degree == 1
    x = np.array([17.0, 0.31, 0.07, 3.9])  # not a node
    got = surfaces(x)
    want = coefficients[:, 0] + coefficients[:, 1:] @ record.unit(x)
    assert np.allclose([got[c] for c in law], want, atol=1e-8)
    assert max(surfaces.expected_error(x).values()) < 1e-6  # the LOO of a linear set is exact


def test_a_pilot_size_set_interpolates_its_nodes(tmp_path):
    rows = _synthetic_rows(3, np.random.default_rng(4).uniform(
        -1.0, 1.0, (len(record_dataset.law_columns()), 5)))
    (tmp_path / "points.csv").write_text(record_dataset.format_rows(rows))
    surfaces, _ = record_law.read_surfaces(tmp_path)
    assert surfaces.degree == 0 and set(surfaces.kernels) == {"linear"}
    for row in rows:
        got = surfaces([row[name] for name in record.AXIS_NAMES])
        assert all(math.isclose(got[c], row[c], abs_tol=1e-9)
                   for c in record_dataset.law_columns())


def test_cycles_round_trip_through_the_row_columns():
    m = record.design_points(1)[0].material()
    y = incipient_yield(m)
    increments = [2e-6 * 0.2 ** (n - 1) for n in range(1, 11)]
    works = [3e-3 * n ** -1.2 for n in range(1, 11)]
    residual, cycles = 0.0, []
    for inc, w in zip(increments, works, strict=True):
        residual += inc
        cycles.append({"max_force_N": 50.0, "max_approach_m": 1e-4 + residual - increments[0],
                       "residual_approach_m": residual, "plastic_work_J": w})
    values = record_dataset.cyclic_columns(cycles, y.force, y.approach)
    assert math.isclose(values["cyclic_residual_08"], 7 * math.log10(0.2))  # 1.3e-5
    assert values["cyclic_residual_09"] == values["cyclic_residual_10"] == -5.0  # the floor
    back = record_dataset.rebuild_cycles(values, y.force, y.approach)
    assert record_dataset.cyclic_columns(back, y.force, y.approach) == pytest.approx(values)
    for n in (2, 3, 5):
        assert math.isclose(back[n - 1]["plastic_work_J"], works[n - 1], rel_tol=1e-9)


def test_a_row_with_too_few_cycles_is_refused():
    cycles = [{"max_force_N": 1.0, "max_approach_m": 1.0, "residual_approach_m": 0.1,
               "plastic_work_J": 0.1}]
    with pytest.raises(InputError, match="has 1 cycles, expected 10"):
        record_dataset.cyclic_columns(cycles, 1.0, 1.0)


# --- one-line errors -------------------------------------------------------------------------
@pytest.mark.parametrize("count", [0, 5000, 2.5, True])
def test_bad_point_counts_are_one_line(count):
    with pytest.raises(InputError, match=r"points: need an integer in \[1, 4096\]"):
        record.design_points(count)


def test_bad_settings_and_flags_are_one_line(capsys):
    from geocontact.universal.campaign import main

    with pytest.raises(InputError, match="mesh"):
        record.fe_settings(mesh="huge")
    assert main(["--points", "3", "--mesh", "coarse"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--mesh: only with --design record" in err
    assert main(["--points", "3", "--design", "record", "--scheduler", "tcp://x:1"]) == 2
    assert "--scheduler" in capsys.readouterr().err
    assert main(["--points", "3", "--step-control", "fixed"]) == 2
    assert "--step-control: only with --design record" in capsys.readouterr().err


def test_the_campaign_flags_reach_the_settings(monkeypatch):
    """No flags: the FE of record; the pilot's flags give the pilot's settings."""
    from geocontact.universal import campaign, record_campaign

    seen = []
    monkeypatch.setattr(record_campaign, "run_points",
                        lambda count, dataset, cache, settings, only=None: seen.append(
                            settings) or [])
    assert campaign.main(["--points", "3", "--design", "record"]) == 0
    assert campaign.main(["--points", "3", "--design", "record", "--mesh", "coarse",
                          "--mesh-rule", "yield", "--step-control", "fixed",
                          "--step-rule", "segment", "--newton", "full"]) == 0
    assert seen == [record.fe_settings(), record.fe_settings(**record.PILOT_FE)]
    assert (seen[0].step_control, seen[0].newton) == ("envelope", "backtracking")


def test_a_point_made_with_other_fe_settings_is_made_again(tmp_path, monkeypatch):
    """Every point of the dataset is of one FE: a point whose provenance records other
    settings (the repeated history made with "dissipation" before "envelope"), or a run made by
    FE code the current code does not reproduce, is not done."""
    from geocontact.fem.identity import fe_code_hash
    from geocontact.universal import record_campaign

    settings = record.fe_settings()
    assert settings.step_control == "envelope"
    older = record.fe_settings(step_control="dissipation")

    def runs(*made):
        return [{"key": "k", "fe_code": code, "step_control": control} for code, control in made]

    now = fe_code_hash()
    (tmp_path / "provenance.json").write_text(json.dumps({"points": {
        "1": {"fe_settings": settings.as_dict(),
              "runs": runs(("4aeedf54d2157bf5", "dissipation"), (now, "envelope"))},
        "3": {"fe_settings": older.as_dict(), "runs": runs((now, "dissipation"))},
        "5": {"fe_settings": settings.as_dict(),
              "runs": runs(("b91341923e5d4e1f", "dissipation"), (now, "envelope"))},
        "7": {"fe_settings": settings.as_dict(),
              "runs": runs((now, "dissipation"), ("b91341923e5d4e1f", "envelope"))},
        "11": {"fe_settings": settings.as_dict(),
               "runs": runs((now, "dissipation"), ("4a1e7207570fa809", "envelope"))},
        "9": {"fe_settings": settings.as_dict(), "cache_keys": ["k"]}}}))
    monkeypatch.setattr(record_campaign, "read_points",
                        lambda directory: {"index": np.array([1.0, 3.0, 5.0, 7.0, 9.0, 11.0])})
    # 4aeedf54 and b9134192's dissipation runs: code the current code reproduces; b9134192's
    # and 4a1e7207's envelope runs: that control has changed since (the rim, 727fa141); a point
    # recorded before "runs": made again
    assert record_campaign._done(tmp_path, settings) == {1, 5}
    assert record_campaign._done(tmp_path, older) == {3}


def test_processes_adding_points_to_one_dataset_take_turns(tmp_path):
    """The folder lock the campaign rewrites its files under: a second process waits for the
    first, so neither rewrites from files the other is about to change."""
    import subprocess
    import sys
    import time

    from geocontact.files import folder_lock

    child = subprocess.Popen([sys.executable, "-c", (
        "import sys, time, pathlib\n"
        "from geocontact.files import folder_lock\n"
        "d = pathlib.Path(sys.argv[1])\n"
        "with folder_lock(d):\n"
        "    (d / 'held').write_text('x')\n"
        "    time.sleep(1.0)\n"
        "    (d / 'child').write_text('done')\n"), str(tmp_path)])
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "held").exists():
            assert time.monotonic() < deadline and child.poll() is None
            time.sleep(0.02)
        with folder_lock(tmp_path):
            assert (tmp_path / "child").read_text() == "done"
    finally:
        child.wait(timeout=60)
    assert child.returncode == 0


def test_record_law_refuses_outside_the_box_and_an_empty_dataset(tmp_path):
    from geocontact.grain.material import Material

    outside = Material(youngs_modulus=1e10, poissons_ratio=0.25, compressive_yield_stress=1e10 / 10,
                       friction_angle_deg=30.0, hardening_ratio=0.1, radius=0.01)
    with pytest.raises(InputError, match=r"outside the universal law's range \[30, 1e\+05\]"):
        record_law.record_params(outside, tmp_path)
    inside = Material(youngs_modulus=1e10, poissons_ratio=0.25, compressive_yield_stress=1e7,
                      friction_angle_deg=30.0, hardening_ratio=0.1, radius=0.01)
    with pytest.raises(InputError, match="no points.csv"):
        record_law.record_params(inside, tmp_path)


def test_params_design_record_needs_a_dataset(tmp_path, capsys):
    from geocontact.cli import main

    code = main(["params", "--material", "reference", "--design", "record",
                 "--out", str(tmp_path / "P.json")])
    assert code == 2
    assert "--design record: needs --dataset" in capsys.readouterr().err
    assert not (tmp_path / "P.json").exists()


# --- the pilot ---------------------------------------------------------------------------------
pilot = pytest.mark.skipif(not (PILOT / "provenance.json").exists(),
                           reason="the pilot's dataset is not committed")


@pilot
def test_pilot_levels_reach_their_target_contact_radius():
    """The level rule on the FE: each level's achieved a/R within 10 % of its target (the probe's
    curve and the level's own run differ by their meshes and load steps), the top near 0.3 R or
    the validity limit."""
    provenance = json.loads((PILOT / "provenance.json").read_text())
    assert provenance["points"]
    for info in provenance["points"].values():
        target = np.array(info["levels"]["target_contact_over_radius"])
        achieved = np.array(info["levels"]["achieved_contact_over_radius"])
        assert np.all(np.abs(achieved / target - 1.0) < 0.10), (target, achieved)
        assert 0.2 <= achieved[-1] <= 0.35


@pilot
def test_pilot_law_file_carries_its_range_and_the_cyclic_extension():
    from geocontact.law import load_params

    data = record_dataset.read_points(PILOT)
    laws = sorted(PILOT.glob("law-point-*.json"))
    assert data["index"].size < 2 or len(laws) == data["index"].size
    for path in laws:
        params = load_params(path)
        index = int(path.stem.rpartition("-")[2])
        row = int(np.flatnonzero(data["index"] == index)[0])
        top = 10 ** data[f"contact_{record.LEVELS - 1}"][row]
        assert params.calibrated_range["contact_radius_ratio"] <= top * (1 + 1e-6)
        assert "cyclic" in params.provenance


@pilot
def test_pilot_law_at_a_node_is_its_own_data(tmp_path):
    """At a pilot point the interpolation is exact: the law's calibrated range ends at the
    point's own top level (force and a/R), its levels are the point's, its cyclic extension is
    the one fits.json records for the point; the stored LOO selection equals a recomputed one."""
    import shutil

    from geocontact.universal.design import material_at

    shutil.copy(PILOT / "points.csv", tmp_path / "points.csv")
    assert record_law.prepare(tmp_path) >= 2
    data = record_dataset.read_points(tmp_path)
    fits = json.loads((tmp_path / "fits.json").read_text())
    cached, _ = record_law.read_surfaces(tmp_path)
    fresh = record_law.build_surfaces(data, cached.dataset_sha256)
    assert cached.kernels == fresh.kernels and np.allclose(cached.loo_error, fresh.loo_error)
    for i in range(data["index"].size):
        material = material_at([data[n][i] for n in record.AXIS_NAMES])
        p = record_law.record_params(material, tmp_path)
        fy = incipient_yield(material).force
        top = record.LEVELS - 1
        assert math.isclose(p.calibrated_range["contact_radius_ratio"],
                            10 ** data[f"contact_{top}"][i], rel_tol=1e-6)
        assert math.isclose(p.calibrated_range["max_force_N"], 10 ** data[f"logf_{top}"][i] * fy,
                            rel_tol=1e-6)
        node = fits["nodes"][str(int(data["index"][i]))]
        assert p.cyclic.enabled == node["cyclic"]["enabled"]
        assert p.provenance["universal"]["saturating_fit_start"].startswith("the fits of")


@pilot
def test_pilot_law_warns_beyond_its_top_level():
    """The law of record says when a contact goes beyond the campaign's top level (the
    calibrated range every law file carries), as any law file does."""
    from geocontact.law import BeyondCalibratedRangeWarning, Contact, load_params

    params = load_params(PILOT / "law-point-0.json")
    top = params.calibrated_range["max_approach_m"]
    import warnings

    contact = Contact(params)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BeyondCalibratedRangeWarning)
        contact.update(0.9 * top)  # inside: silent
    with pytest.warns(BeyondCalibratedRangeWarning, match="beyond the calibrated range"):
        contact.update(1.2 * top)


# --- a probe the FE cannot finish -------------------------------------------------------------
RECORD_CACHE = Path(__file__).resolve().parent.parent / "datasets/fe-runs/universal-record"


def _failed_probe_in(cache: Path):
    """Point 5's first probe (E/sigma_c 1e5, beta 60 deg, nu 0.1, m 0; Newton failed at 1221 N,
    its checkpoint committed at the last converged step, under the key the campaign last gave
    it) as a job with its checkpoint in ``cache`` under the job's key of the current FE code
    (as the campaign adopts it)."""
    import shutil

    from geocontact.fem.campaign import FemJob
    from geocontact.fem.checkpoint import checkpoint_path

    material = record.design_points(64)[5].material().to_dict()
    for path in sorted(RECORD_CACHE.glob("*.checkpoint.npz")):
        with np.load(path, allow_pickle=False) as data:
            inputs = json.loads(str(data["identity"]))["inputs"]
        if inputs["material"] == material and inputs["mesh"] == "coarse":
            job = FemJob.of_inputs(inputs)
            shutil.copyfile(path, checkpoint_path(cache / job.key()))
            return job
    raise AssertionError("point 5's failed probe: no committed checkpoint")


def test_a_probe_the_fe_cannot_finish_stands_for_its_converged_steps(tmp_path, monkeypatch):
    """Its converged steps are read from its checkpoint and end the probing; the base aims at
    FAILED_PROBE_FORCE x the last converged force at most, so it is not driven into the
    failure; without a checkpoint the failure is the point's."""
    from geocontact.fem.campaign import CampaignError
    from geocontact.universal import record_campaign

    job = _failed_probe_in(tmp_path)
    calls = []

    def failing(jobs, cache, **kwargs):
        calls.append(jobs[0].key())
        raise CampaignError("campaign: 1 of 1 FE runs failed", [])

    monkeypatch.setattr("geocontact.fem.campaign.run_campaign", failing)
    monkeypatch.setattr(record, "probe_job", lambda *args, **kwargs: job)
    point = record.design_points(64)[5]
    probes, results = record_campaign.run_probes(point, job.settings(), tmp_path,
                                                 progress=False)
    assert calls == [job.key()] and probes == [job]  # no deeper probe after a failure
    failed = results[0]
    assert isinstance(failed, record_campaign.FailedRun)
    assert failed.reached_N == pytest.approx(1197.0, rel=1e-3)  # step 24 of 25
    assert "1 of 1 FE runs failed" in failed.error
    force, radius = record.contact_curve(failed.curve)
    assert radius[-1] / point.material().radius == pytest.approx(0.2567, rel=1e-3)
    base = record.base_force(point.material(), force, radius, failed=True)
    assert base == pytest.approx(record.FAILED_PROBE_FORCE * failed.reached_N)
    # the same curve as a finished probe: the base would be aimed past the failure
    assert record.base_force(point.material(), force, radius) > failed.reached_N
    # the levels on that reach: seven, the lowest at 2 Fy (below this probe's first loaded
    # step, 9.3e-7 N: its contact is Hertz's), the top where the curve ends
    below = force <= base
    levels = record.level_forces(point.material(), force[below], radius[below])
    fy = incipient_yield(point.material()).force
    assert len(levels["forces_N"]) == record.LEVELS and levels["forces_N"][-1] <= base
    assert levels["forces_N"][0] == pytest.approx(2.0 * fy) and 2.0 * fy < force[0]
    # no checkpoint: the probe's failure is the point's
    (tmp_path / "empty").mkdir()
    with pytest.raises(CampaignError):
        record_campaign.run_probes(point, job.settings(), tmp_path / "empty", progress=False)


def test_a_failed_probe_aims_the_base_below_its_reach_only_where_it_would_pass_it():
    """``base_force(failed=True)``: the usual aim where that is below FAILED_PROBE_FORCE x the
    reach (a failure beyond the top target changes nothing), else the cap, with the levels
    then inside the base's reach."""
    material = record.design_points(64)[0].material()
    force = np.geomspace(1.0, 1e6, 60)
    radius = 0.1 * 0.5 * (force / 1e6) ** 0.5  # a/R 0.0158 ... 0.5
    usual = record.base_force(material, force, radius)
    assert usual < record.FAILED_PROBE_FORCE * force[-1]
    assert record.base_force(material, force, radius, failed=True) == usual
    short = force <= 0.2 * 1e6  # a probe that failed at a/R 0.22
    capped = record.base_force(material, force[short], radius[short], failed=True)
    assert capped == pytest.approx(record.FAILED_PROBE_FORCE * force[short][-1])
    assert record.base_force(material, force[short], radius[short]) > force[short][-1]
    below = force <= capped
    levels = record.level_forces(material, force[below], radius[below])
    assert len(levels["forces_N"]) == record.LEVELS and levels["forces_N"][-1] <= capped


def test_a_base_the_fe_cannot_finish_gives_levels_and_branches_within_its_reach(monkeypatch):
    """The base's failure is caught, its converged steps (``FailedRun``) place the levels, and
    every branch follows it at one of those steps; run again for its snapshots, its failure at
    the end is expected, while a finished base's is not."""
    from geocontact.errors import ConvergenceError
    from geocontact.fem.campaign import CampaignError
    from geocontact.fem.result import CURVE_COLUMNS
    from geocontact.universal import record_campaign

    point = record.design_points(64)[0]
    material = point.material()
    fy = incipient_yield(material).force
    force = np.geomspace(0.5 * fy, 3000.0 * fy, 120)  # a/R up to ~0.2, then the failure
    radius = 0.1 * material.radius * (force / (300.0 * fy)) ** 0.5
    curve = {name: np.zeros(len(force)) for name in CURVE_COLUMNS}
    curve.update(force_N=force, contact_radius_m=radius)
    monkeypatch.setattr(record_campaign, "run_probes",
                        lambda *args, **kwargs: ([None], [type("R", (), {"curve": curve})()]))

    def base_fails(jobs, cache, **kwargs):
        raise CampaignError("campaign: 1 of 1 FE runs failed: the base", [])

    reached = force[force <= 0.6 * force[-1]]
    failed_base = record_campaign.FailedRun(
        {name: values[: len(reached)] for name, values in curve.items()}, "the base failed")
    monkeypatch.setattr("geocontact.fem.campaign.run_campaign", base_fails)
    monkeypatch.setattr(record_campaign.FailedRun, "of",
                        classmethod(lambda cls, job, cache, error: failed_base))
    seen = {}

    class Stop(Exception):
        pass

    def snapshots(base, branches, cache, progress, failed=False):
        seen.update(base=base, branches=branches, failed=failed)
        raise Stop

    monkeypatch.setattr(record_campaign, "_snapshots_for", snapshots)
    with pytest.raises(Stop):
        record_campaign.run_point(point, record.fe_settings(), Path("unused"), progress=False)
    assert seen["failed"] is True
    steps = [branch.follows[1] for branch in seen["branches"]]
    assert len(steps) == record.LEVELS + 1 and max(steps) < len(reached)
    assert all(branch.follows[0] == seen["base"].forces for branch in seen["branches"])

    # run again for its snapshots: a failed base's failure is expected, a finished one's not
    monkeypatch.undo()
    calls = []

    def fails(*args, **kwargs):
        calls.append(kwargs.get("snapshots"))
        raise ConvergenceError("Newton did not converge")

    monkeypatch.setattr("geocontact.fem.run.run_history", fails)
    monkeypatch.setattr("geocontact.fem.campaign.adopt_snapshots",
                        lambda cache, job, progress=False: Path("/nonexistent/steps"))
    base = record.base_job(point, record.fe_settings(), 1000.0)
    branch = record.job(material, [0.0, 10.0, 0.0], record.fe_settings(), "branch", 1000.0,
                        follows=(base.forces, 3))
    cache = Path("/nonexistent/cache")
    record_campaign._snapshots_for(base, [branch], cache, False, failed=True)
    with pytest.raises(ConvergenceError):
        record_campaign._snapshots_for(base, [branch], cache, False)
    assert len(calls) == 2
