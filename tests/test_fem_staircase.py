"""The staircase of a growing contact (issue 15, part 1): the measures that detect it, the
"contact" mesh rule (small surface elements over the plastic range of contact radii) and the
"decade" step rule (geometric loading steps per decade of force), the load-step control
``max_step_ratio`` (sub-steps capped in force ratio on plastic loading). The long runs are in
scripts/measure_staircase.py (docs/fem.md, "The staircase of a growing contact"); here only a
short coarse run of the weak grain checks the control against finer load steps."""

import math

import numpy as np
import pytest
from conftest import YIELD_FIXED

import geocontact.fem.run as fem_run
from geocontact.errors import InputError
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.mesh import (
    CONTACT_DENSE_FACTOR,
    CONTACT_SURFACE_GRADING,
    build_mesh,
    surface_vertex_radii,
)
from geocontact.fem.run import (
    contact_band_radius,
    history_mesh,
    load_schedule,
    run_history,
    sub_step_record,
    sub_steps,
)
from geocontact.fem.staircase import (
    approach_gap,
    bump_correlation,
    force_gap,
    gap_by_decade,
    sampling_gap,
    slope_measures,
    staircase_measures,
)
from geocontact.grain.hertz import incipient_yield
from geocontact.grain.material import preset


def _power_law(n=60):
    x = np.geomspace(1e-6, 1e-3, n)
    return x, 1e9 * x ** 1.2


def _staircase(n=60, stairs=12):
    """F flat between engagements (plateaus), then a steep riser."""
    x, f = _power_law(400)
    level = np.exp(np.floor(np.log(f) / (np.log(f[-1] / f[0]) / stairs)) * (
        np.log(f[-1] / f[0]) / stairs))
    keep = np.linspace(0, len(x) - 1, n).astype(int)
    return x[keep], np.maximum(level[keep], f[0])


def test_measures_tell_a_staircase_from_a_smooth_curve():
    x, f = _power_law()
    smooth = slope_measures(x, f, 0.0)
    assert smooth["slope_total_variation"] < 1e-6 and abs(smooth["slope_min"] - 1.2) < 1e-9
    xs, fs = _staircase()
    stairs = slope_measures(xs, fs, 0.0)
    assert stairs["slope_total_variation"] > 20 and stairs["slope_min"] < 0.1
    # the same smooth curve sampled at other points: no gap; a staircase against it: large
    x2, f2 = _power_law(37)
    assert force_gap((x, f), (x2, f2), 0.0)[0] < 1e-6
    assert force_gap((x, f), (xs, fs), 0.0)[0] > 0.1
    curves = {"a": {"force_N": np.r_[0.0, f], "approach_m": np.r_[0.0, x]},
              "b": {"force_N": np.r_[0.0, f2], "approach_m": np.r_[0.0, x2]}}
    measures = staircase_measures(curves, yield_force=1e-3, floor=10.0)
    assert measures["pairs"]["a vs b"]["force_gap_max"] < 1e-6


def test_approach_gap_compares_only_the_forces_both_runs_recorded():
    """A run recording every other point of another: the approach gap is over the shared
    forces only, exact there (a staircase's risers between them do not count); a run 2 % softer
    at the same forces shows 2 %; the force gap is binned by decade of force."""
    x, f = _power_law(61)
    half = (x[::2], f[::2])
    gap = approach_gap((x, f), half, 0.0)
    assert gap["common_forces"] == 31 and gap["approach_gap_max"] < 1e-12
    softer = approach_gap((1.02 * x, f), half, 0.0)
    assert abs(softer["approach_gap_max"] - 0.02) < 1e-12
    assert abs(softer["approach_gap_rms"] - 0.02) < 1e-12
    xs, fs = _staircase(61)
    fs = fs * np.geomspace(1.0, 1.01, len(fs))  # plateaus rising a little: a loading branch
    assert approach_gap((xs, fs), (xs[::2], fs[::2]), 0.0)["approach_gap_max"] < 1e-12
    assert force_gap((xs, fs), (xs[::2], fs[::2]), 0.0)[0] > 0.01  # interpolation over risers
    # ... which is all sampling: the same curve kept at every other point gives the same gap
    assert sampling_gap((xs, fs), (xs[::2], fs[::2]), 0.0) == force_gap(
        (xs, fs), (xs[::2], fs[::2]), 0.0)
    assert sampling_gap((x, f), half, 0.0)[0] < 1e-9  # a power law interpolates exactly
    decades = gap_by_decade(np.array([5.0, 50.0, 60.0, 500.0]),
                            np.array([0.01, -0.03, 0.02, 0.001]))
    assert decades == {"1e0-1e1": 0.01, "1e1-1e2": 0.03, "1e2-1e3": 0.001}


def test_bump_correlation_tells_shared_bumps_from_independent_ones():
    """Two samplings of one bumpy curve (every point, every other point) have the same bumps:
    correlation near 1 (each about its own cubic fit, which the sampling moves a little). The
    same smooth curve with independent bumps of the same size: near 0. The smooth part (any
    cubic in ln F) is not a bump; forces more than BUMP_DECADES below the largest are left
    out."""
    rng = np.random.default_rng(7)
    f = np.geomspace(1.0, 1e4, 241)
    lf = np.log(f)
    smooth = -12.0 + 0.9 * lf - 0.01 * lf**2 + 1e-4 * lf**3
    wiggle = 0.006 * rng.standard_normal(len(f))
    a = (np.exp(smooth + wiggle), f)
    same = bump_correlation(a, (a[0][::2], f[::2]), 0.0)
    assert same["bump_correlation"] > 0.95
    assert same["bump_rms_difference"] < 0.3 * same["bump_rms_a"]
    assert 0.004 < same["bump_rms_a"] < 0.008
    assert same["bump_forces"] == 61  # 100 N ... 1e4 N, every other point of 121
    other = (np.exp(smooth + 0.006 * rng.standard_normal(len(f))), f)
    independent = bump_correlation(a, other, 0.0)
    assert abs(independent["bump_correlation"]) < 0.4
    assert independent["bump_rms_difference"] > 0.006
    assert bump_correlation((np.exp(smooth), f), (np.exp(smooth), f), 0.0)[
        "bump_rms_a"] < 1e-12


def test_contact_rule_refines_the_surface_over_the_plastic_contact_radii():
    """On the weak grain sized for 6000 N the surface edge at a contact radius a in the band is
    ~ a / CONTACT_SURFACE_GRADING (a node every 1.25 % of a on coarse), against a / 5 with the
    verified "yield" rule, and half that with "contact-dense"; inside the body (the depth
    growth) the meshes stay alike."""
    material = preset("reference-weak")
    meshes = {rule: history_mesh(material, 6000.0, "coarse", rule=rule)
              for rule in ("yield", "contact", "contact-dense")}
    a_y = float(incipient_yield(material).contact_radius)
    assert 1.5 * a_y < contact_band_radius(material) < 5 * a_y  # the contact at 10 Fy
    spacing = {}
    for rule, mesh in meshes.items():
        ends = surface_vertex_radii(mesh, material.radius)
        mid = 0.5 * (ends[1:] + ends[:-1])
        sel = (mid > 0.002) & (mid < 0.02)  # contact radii of 50 ... 6000 N
        spacing[rule] = np.max(np.diff(ends)[sel] / mid[sel])
    assert spacing["yield"] > 0.15
    assert spacing["contact"] < 1.3 / CONTACT_SURFACE_GRADING["coarse"]
    dense = CONTACT_DENSE_FACTOR * CONTACT_SURFACE_GRADING["coarse"]
    assert 0.7 / dense < spacing["contact-dense"] < 1.3 / dense
    counts = {rule: mesh.t.shape[1] for rule, mesh in meshes.items()}
    assert counts["contact"] < 5 * counts["yield"]  # linear in the grading, not quadratic
    assert counts["contact-dense"] < 2.2 * counts["contact"]


def test_yield_rule_is_the_verified_mesh():
    material = preset("reference")
    a = build_mesh(material.radius, 2e-4, 5e-3, "coarse")
    b = build_mesh(material.radius, 2e-4, 5e-3, "coarse", rule="yield")
    assert np.array_equal(a.p, b.p) and np.array_equal(a.t, b.t)
    with pytest.raises(InputError, match="^mesh_rule: unknown 'fine'"):
        build_mesh(material.radius, 2e-4, 5e-3, "coarse", rule="fine")


def test_decade_step_rule_adds_geometric_steps_only_where_decades_are_many():
    fy = 0.00276  # the weak grain's first-yield force
    forces = [0.0, 6000.0, 0.0]
    segment, _ = load_schedule(forces, 24, fy)
    decade, marks = load_schedule(forces, 24, fy, "decade")
    loading = np.array([f for f in decade[:marks[0]]])
    geometric_span = math.log10(6000.0 / (0.5 * fy))
    assert len(decade) > len(segment)
    ratios = loading[1:] / loading[:-1]
    # >= 12 per decade (one point of a near-duplicate pair within 2 % is merged away)
    assert np.max(ratios[loading[1:] > fy]) <= 10 ** (1 / 12) * 1.02
    assert marks[0] >= 12 * geometric_span
    # unloading is the same; a history of 1.6 decades (0.5 Fy ... 20 Fy) gets no extra steps
    assert decade[marks[0]:] == segment[len(segment) - (len(decade) - marks[0]):]
    short, _ = load_schedule([0.0, 20 * fy], 24, fy, "decade")
    assert short == load_schedule([0.0, 20 * fy], 24, fy)[0]
    with pytest.raises(InputError, match="^step_rule: unknown 'x'"):
        FeRunIdentity.of(preset("reference"), [0.0, 10.0], step_rule="x")
    assert "step_rule" in FeRunIdentity.of(preset("reference"), [0.0, 10.0],
                                           step_rule="decade").inputs()


def test_sub_steps_honour_the_cap_on_plastic_loading_only():
    fy = 0.00276
    steps = sub_steps(1.0, 2.0, fy, 1.05)
    assert steps[-1] == 2.0 and len(steps) == math.ceil(math.log(2.0) / math.log(1.05))
    ratios = np.array(steps) / np.array([1.0, *steps[:-1]])
    assert np.all(ratios <= 1.05 + 1e-12) and np.ptp(ratios) < 1e-9  # geometric
    assert sub_steps(1.0, 2.0, fy, None) == [2.0]
    assert sub_steps(2.0, 1.0, fy, 1.05) == [1.0]  # unloading: one solve
    assert sub_steps(0.0, 0.5 * fy, fy, 1.05) == [0.5 * fy]  # elastic: one solve
    crossing = sub_steps(0.5 * fy, 1.5 * fy, fy, 1.05)
    assert crossing[0] == fy and crossing[-1] == 1.5 * fy  # elastic to Fy, then capped
    schedule, _ = load_schedule([0.0, 6000.0, 0.0], 24, fy)
    record = sub_step_record(schedule, fy, 1.02)
    assert record["largest_loading_ratio_above_yield"] <= 1.02 + 1e-12
    assert record["solves"] >= math.log(6000.0 / fy) / math.log(1.02)
    assert record["requested_steps"] == len(schedule)
    assert sub_step_record(schedule, fy, None)["solves"] == len(schedule)
    material = preset("reference-weak")
    capped = FeRunIdentity.of(material, [0.0, 1.0], max_step_ratio=1.02)
    assert capped.inputs()["max_step_ratio"] == 1.02
    assert "max_step_ratio" not in FeRunIdentity.of(material, [0.0, 1.0]).inputs()
    assert capped.key() != FeRunIdentity.of(material, [0.0, 1.0], max_step_ratio=1.01).key()
    for bad in (1.0, 3.0, "x", True, math.nan):
        with pytest.raises(InputError, match="^max_step_ratio: must be a number in"):
            FeRunIdentity.of(material, [0.0, 1.0], max_step_ratio=bad)


def test_capped_steps_bring_a_coarse_run_close_to_a_fine_step_one(tmp_path, monkeypatch):
    """The weak grain 0 -> 0.3 N (F/Fy ~ 110, perfectly plastic flattening), coarse mesh: 3
    requested steps per segment are a factor ~2.5 apart in force and overestimate the approach
    by ~1.5 % against 24 steps; the same 3 steps solved through sub-steps of at most x1.15 are
    within a few tenths of a per cent (first order in the step: docs/fem.md). The requested
    steps are still the recorded ones, the cap is recorded, and an interrupted capped run
    resumes to the same curve."""
    material = preset("reference-weak")
    forces = [0.0, 0.3]

    def run(**kwargs):
        return run_history(material, forces, "coarse", write_fields=False, **YIELD_FIXED,
                           **kwargs)

    reference = run(steps_per_segment=24).curve["approach_m"][-1]
    plain = run(steps_per_segment=3)
    capped = run(steps_per_segment=3, max_step_ratio=1.15)
    error = {name: abs(r.curve["approach_m"][-1] / reference - 1.0)
             for name, r in (("plain", plain), ("capped", capped))}
    assert error["plain"] > 0.01
    assert error["capped"] < error["plain"] / 4
    assert np.array_equal(capped.curve["force_N"], plain.curve["force_N"])
    control = capped.summary["step_control"]
    assert control["max_step_ratio"] == 1.15
    assert control["largest_loading_ratio_above_yield"] <= 1.15
    assert control["solves"] > 3 * control["requested_steps"]
    assert capped.summary["identity"]["inputs"]["max_step_ratio"] == 1.15
    assert np.sum(capped.curve["iterations"]) > np.sum(plain.curve["iterations"])

    real = fem_run._advance

    def interrupted(solver, state, target, k, *goals):
        if k == 5:
            raise KeyboardInterrupt
        return real(solver, state, target, k, *goals)

    out = tmp_path / "capped"
    with monkeypatch.context() as m:
        m.setattr(fem_run, "_advance", interrupted)
        with pytest.raises(KeyboardInterrupt):
            run(steps_per_segment=3, max_step_ratio=1.15, out=out)
    calls = []

    def counted(solver, state, target, k, *goals):
        calls.append(k)
        return real(solver, state, target, k, *goals)

    with monkeypatch.context() as m:
        m.setattr(fem_run, "_advance", counted)
        resumed = run(steps_per_segment=3, max_step_ratio=1.15, out=out, resume=True)
    assert calls[0] == 5  # went on from the checkpoint
    for name in ("force_N", "approach_m", "plastic_dissipation_J", "iterations"):
        assert np.allclose(resumed.curve[name], capped.curve[name], rtol=1e-10, atol=0.0), name


def test_measure_of_the_committed_staircase_runs_under_way(tmp_path):
    """scripts/measure_staircase.py --under-way on datasets/staircase (no FE run): the node
    contact's finished default-mesh runs (FE code the current one reproduces) and the facet
    contact's runs, finished or still at their committed checkpoints, are measured together up
    to the lowest force all of them reached."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    out = tmp_path / "staircase.json"
    done = subprocess.run(
        [sys.executable, str(root / "scripts" / "measure_staircase.py"), "--material",
         "reference-weak", "--mesh", "default", "--kinematics", "finite", "--mesh-rule",
         "contact", "--max-step-ratio", "1.01", "--contact", "node", "facet", "--steps", "24",
         "48", "--out", str(root / "datasets" / "staircase"), "--under-way", "--json", str(out)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    measures = json.loads(out.read_text())
    assert len(measures["runs"]) == 4  # node and facet, 24 and 48 steps
    reached = [run["force_N"] for run in measures["under_way"].values()]
    if reached:
        assert measures["measured_to_force_N"] == pytest.approx(min(reached))
    else:
        assert measures["measured_to_force_N"] is None
    node = measures["pairs"]["node, 24 steps, cap 1.01 vs node, 48 steps, cap 1.01"]
    assert node["force_gap_max"] < 0.02  # 1.56 % over the whole loading (docs/fem.md)
    # the contact discretisation moves the loading curve by less than the law's fit error
    for steps in (24, 48):
        pair = measures["pairs"][f"node, {steps} steps, cap 1.01 vs facet, {steps} steps, cap 1.01"]
        assert pair["force_gap_max"] < 0.03
        # the bumps left are the discretisation's, not the load steps': 24 and 48 steps of one
        # contact have the same bumps (0.96-0.97), the node and facet contacts on the same mesh
        # only half the same (0.49-0.53; docs/fem.md)
        assert pair["bump_correlation"] < 0.7
    for contact in ("node", "facet"):
        pair = measures["pairs"][f"{contact}, 24 steps, cap 1.01 vs {contact}, 48 steps, cap 1.01"]
        # one run alone gives the pair's sampling gap: against itself at the 24-step forces
        run = measures["runs"][f"{contact}, 48 steps, cap 1.01"]
        assert run["sampling_gap_half_max"] == pytest.approx(pair["sampling_gap_max"], rel=1e-9)
        assert 0.004 < run["bump_rms"] < 0.01
        assert pair["bump_correlation"] > 0.9
        assert pair["bump_rms_difference"] < 0.4 * pair["bump_rms_a"]


def test_contact_dense_pair_meets_the_staircase_goal_to_6_kN(tmp_path):
    """The issue's measure on the FE that meets it (docs/fem.md, "On the default preset"): the
    weak grain loaded 0 -> 6000 N with finite strain on the default preset's "contact-dense"
    mesh rule, 24 vs 48 load steps per segment, recomputed from the committed finished runs (no
    FE run): within 1 % in force at the same approach over the whole loading, and a local
    log-slope with no spike; the "contact" mesh rule's pair, measured the same way, is not."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    measures = {}
    for rule in ("contact", "contact-dense"):
        out = tmp_path / f"{rule}.json"
        done = subprocess.run(
            [sys.executable, str(root / "scripts" / "measure_staircase.py"), "--material",
             "reference-weak", "--mesh", "default", "--kinematics", "finite", "--mesh-rule", rule,
             "--max-step-ratio", "1.01", "--steps", "24", "48", "--out",
             str(root / "datasets" / "staircase"), "--finished-only", "--json", str(out)],
            capture_output=True, text=True, timeout=300, cwd=tmp_path)
        assert done.returncode == 0, done.stderr[-2000:]
        measures[rule] = json.loads(out.read_text())
    dense = measures["contact-dense"]
    assert dense["force_N"] == 6000.0 and dense["measured_to_force_N"] is None  # both finished
    pair = dense["pairs"]["24 steps, cap 1.01 vs 48 steps, cap 1.01"]
    assert pair["common_forces"] >= 40
    assert pair["force_gap_max"] < 0.01  # the goal; 0.68 % measured
    assert pair["force_gap_max_by_decade"]["1e3-1e4"] < 0.01  # it holds at the largest loads
    contact = measures["contact"]["pairs"]["24 steps, cap 1.01 vs 48 steps, cap 1.01"]
    assert contact["force_gap_max"] > 0.01  # 1.56 %: the surface spacing is what met the goal
    for run in dense["runs"].values():
        assert run["slope_jump_max"] < 1.0  # no riser: a staircase has jumps of 4-38
        assert 0.5 < run["slope_min"] and run["slope_max"] < 1.5
        assert run["bump_rms"] < 0.005


def test_waypoint_gaps_compare_each_peak_and_return_to_zero():
    """scripts/measure_staircase.py --cycles: each run's approach at every peak and every return
    to 0 N (the ends of the monotonic segments, recorded whatever the steps), and per pair the
    largest relative difference there, peaks and residuals apart (synthetic curves of two cycles
    0 -> 1 -> 0 -> 1 -> 0, one run 24 steps, the other 48, 2 % and 10 % apart at the ends)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "scripts" / "measure_staircase.py"
    spec = importlib.util.spec_from_file_location("measure_staircase", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)

    def run(steps, peaks, rests):
        up = np.linspace(0.0, 1.0, steps + 1)
        force = np.concatenate([up, up[::-1][1:], up[1:], up[::-1][1:]])
        ends = [peaks[0], rests[0], peaks[1], rests[1]]
        approach = np.concatenate([
            np.linspace(0.0, ends[0], steps + 1), np.linspace(ends[0], ends[1], steps + 1)[1:],
            np.linspace(ends[1], ends[2], steps + 1)[1:],
            np.linspace(ends[2], ends[3], steps + 1)[1:]])
        return {"force_N": force, "approach_m": approach}

    curves = {"a": run(24, [1.0, 1.1], [0.5, 0.6]),
              "b": run(48, [1.0, 1.1 * 1.02], [0.5 / 1.1, 0.6])}
    gaps = script.waypoint_gaps(curves, 5)
    assert gaps["approach_at_waypoints_m"]["a"] == pytest.approx([1.0, 0.5, 1.1, 0.6])
    pair = gaps["pairs"]["a vs b"]
    assert pair["peak_approach_gap_max"] == pytest.approx(1.0 - 1.0 / 1.02, rel=1e-12)
    assert pair["residual_approach_gap_max"] == pytest.approx(0.1, rel=1e-12)
    assert script.waypoint_gaps(curves, 7)["pairs"] == {}  # not the history's waypoints
