"""The adaptive load-step controls (``step_control="adaptive"`` and the default
``"dissipation"``, fem.run.AdaptiveSteps, issue 36): each criterion moves the step the way it
should (synthetic inputs), the sub-steps end on the
requested forces whatever the control, a failed solve is cut and tried again, a coarse run with
it is converged in the load step where today's default is not, and the setting is recorded,
resumed and refused like the others (docs/fem.md, "Adaptive load steps")."""

import argparse
import dataclasses
import math

import numpy as np
import pytest

import geocontact.fem.run as fem_run
from geocontact.cli import main
from geocontact.errors import ConvergenceError, InputError
from geocontact.fem.campaign import FemJob
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.run import (
    ADAPTIVE_CUT,
    ADAPTIVE_EASY_ITERATIONS,
    ADAPTIVE_EDGE_ADVANCE,
    ADAPTIVE_FIRST_RATIO,
    ADAPTIVE_GROWTH,
    ADAPTIVE_HARD_ITERATIONS,
    ADAPTIVE_MAX_RATIO,
    ADAPTIVE_PLASTIC_FLOOR,
    ADAPTIVE_PLASTIC_INCREMENT,
    ADAPTIVE_SAFETY,
    DISSIPATION_FLOOR,
    DISSIPATION_INCREMENT,
    AdaptiveSteps,
    run_history,
)
from geocontact.fem.settings import FeSettings
from geocontact.grain.material import preset

YIELD_STRAIN = 1e-4
ELEMENT = 1e-4  # m: the surface elements of the synthetic mesh


def _control(max_ratio=ADAPTIVE_MAX_RATIO, yield_force=1.0, step_control="adaptive"):
    ends = np.arange(0.0, 0.05 + ELEMENT / 2, ELEMENT)
    return AdaptiveSteps(yield_force, YIELD_STRAIN, ends, math.log(max_ratio), step_control)


def _judge(control, used=0.01, edge=0.0, plastic=0.0, strain=0.01, iterations=3):
    control.log_ratio = used
    return control.judge(used, edge, ELEMENT, plastic, strain, iterations)


def test_the_edge_advance_sets_the_step_only_where_plastic_flow_makes_it_matter():
    control = _control()
    quiet = 1e-6  # a little plastic flow: the edge criterion applies
    # the edge moved a quarter element: half the bound, the next step grows by SAFETY x 2
    assert _judge(control, edge=0.25 * ELEMENT, plastic=quiet) == (True, "growth")
    assert control.log_ratio == pytest.approx(0.01 * ADAPTIVE_GROWTH)
    accepted, reason = _judge(control, edge=ADAPTIVE_EDGE_ADVANCE * ELEMENT * 1.6, plastic=quiet)
    assert (accepted, reason) == (True, "edge")
    assert control.log_ratio == pytest.approx(0.01 * ADAPTIVE_SAFETY / 1.6)
    # past twice the bound: solved again, smaller
    accepted, reason = _judge(control, edge=3 * ADAPTIVE_EDGE_ADVANCE * ELEMENT, plastic=quiet)
    assert (accepted, reason) == (False, "edge") and control.log_ratio < 0.01 * 0.35
    # an elastic solve is path independent: the same advance does not limit it
    assert _judge(control, edge=3 * ADAPTIVE_EDGE_ADVANCE * ELEMENT, plastic=0.0) == (
        True, "growth")
    assert control.element_at(0.5 * ELEMENT) == pytest.approx(ELEMENT)


def test_the_plastic_increment_sets_the_step_against_the_plastic_strain_there():
    control = _control()
    strain = 0.02
    allowed = ADAPTIVE_PLASTIC_INCREMENT * strain
    accepted, reason = _judge(control, plastic=1.5 * allowed, strain=strain)
    assert (accepted, reason) == (True, "plastic")
    assert control.log_ratio == pytest.approx(0.01 * ADAPTIVE_SAFETY / 1.5)
    assert _judge(control, plastic=2.5 * allowed, strain=strain)[0] is False
    # before any plastic strain the bound is ADAPTIVE_PLASTIC_FLOOR yield strains
    floor = ADAPTIVE_PLASTIC_INCREMENT * ADAPTIVE_PLASTIC_FLOOR * YIELD_STRAIN
    assert _judge(control, plastic=1.5 * floor, strain=0.0) == (True, "plastic")
    assert _judge(control, plastic=2.5 * floor, strain=0.0)[0] is False
    assert _judge(control, plastic=0.1 * floor, strain=0.0) == (True, "growth")


def test_newtons_effort_grows_easy_steps_and_cuts_hard_ones_up_to_the_largest():
    control = _control(max_ratio=1.1)
    assert _judge(control, iterations=3) == (True, "growth")
    assert control.log_ratio == pytest.approx(0.01 * ADAPTIVE_GROWTH)
    assert _judge(control, iterations=ADAPTIVE_EASY_ITERATIONS + 1) == (True, "newton")
    assert control.log_ratio == pytest.approx(0.01)
    assert _judge(control, iterations=2 * ADAPTIVE_HARD_ITERATIONS) == (True, "newton")
    assert control.log_ratio == pytest.approx(0.005)
    assert _judge(control, used=0.09, iterations=2) == (True, "largest")
    assert control.log_ratio == pytest.approx(math.log(1.1))
    # a step cut short to end on a requested force keeps the size the control had
    control.log_ratio = 0.05
    assert control.judge(0.001, 0.0, ELEMENT, 0.0, 0.0, 2) == (True, "growth")
    assert control.log_ratio == pytest.approx(0.05)


def test_the_dissipation_bound_sets_the_step_against_the_dissipation_there():
    """"dissipation": the plastic bound is the dissipation a solve adds against the dissipation
    before it (or DISSIPATION_FLOOR of the work of the force); the largest eqps increment,
    however large, no longer sets the step; the edge and Newton act as in "adaptive"."""
    control = _control(step_control="dissipation")
    dissipation = 2.0  # J
    budget = DISSIPATION_INCREMENT * dissipation
    plastic = 1e-3  # an eqps increment 5 x the adaptive control's bound at this strain
    verdict = control.judge(0.01, 0.0, ELEMENT, plastic, 0.002, 3, 1.5 * budget, dissipation,
                            10.0)
    assert verdict == (True, "plastic")
    assert control.log_ratio == pytest.approx(0.01 * ADAPTIVE_SAFETY / 1.5)
    assert control.judge(0.01, 0.0, ELEMENT, plastic, 0.002, 3, 2.5 * budget, dissipation,
                         10.0)[0] is False
    assert control.judge(0.01, 0.0, ELEMENT, plastic, 0.002, 3, 0.1 * budget, dissipation,
                         10.0) == (True, "growth")
    # before any dissipation the budget is DISSIPATION_FLOOR of the work of the force
    floor = DISSIPATION_INCREMENT * DISSIPATION_FLOOR * 10.0
    assert control.judge(0.01, 0.0, ELEMENT, plastic, 0.0, 3, 1.5 * floor, 0.0, 10.0) == (
        True, "plastic")
    assert control.judge(0.01, 0.0, ELEMENT, plastic, 0.0, 3, 2.5 * floor, 0.0, 10.0)[0] is False
    # the edge's advance still bounds a plastic solve
    assert control.judge(0.01, 1.6 * ADAPTIVE_EDGE_ADVANCE * ELEMENT, ELEMENT, plastic, 0.002, 3,
                         0.1 * budget, dissipation, 10.0) == (True, "edge")
    # the same solve under "adaptive": its eqps increment is what cuts it
    assert _control().judge(0.01, 0.0, ELEMENT, plastic, 0.002, 3, 0.1 * budget, dissipation,
                            10.0)[0] is False
    record = control.summary(3)
    assert record["control"] == "dissipation"
    assert record["criteria"]["dissipation_increment_of_dissipation"] == DISSIPATION_INCREMENT
    assert "dissipation_increment_of_dissipation" not in _control().summary(3)["criteria"]


def test_on_a_power_law_dissipation_the_step_settles_without_a_sawtooth():
    """D = F^k above first yield (k ~ 2 on the FE's growing contacts, docs/fem.md "The
    dissipation bound"): the control settles at ln F ratio SAFETY x DISSIPATION_INCREMENT / k,
    with no solve rejected; the work of the force is far above the floor's."""
    control = _control(step_control="dissipation")
    force, k, ratios = 10.0, 2.0, []
    for _ in range(60):
        used = control.log_ratio
        new = force * math.exp(used)
        accepted, _ = control.judge(used, 0.0, ELEMENT, 1e-3, 0.01, 3, new ** k - force ** k,
                                    force ** k, 2.0 * force ** k)
        assert accepted
        ratios.append(used)
        force = new
    steady = ADAPTIVE_SAFETY * DISSIPATION_INCREMENT / k
    assert ratios[-1] == pytest.approx(steady, rel=0.05)
    assert np.ptp(ratios[-10:]) < 0.01 * steady


@dataclasses.dataclass
class _State:
    force: float
    eqps: np.ndarray
    iterations: int = 0
    plastic_dissipation: float = 0.0
    work: float = 0.0


class _Solver:
    """A plastic contact in closed form: a ~ F^(1/2), eqps ~ F^(1/2); Newton fails on a step
    above ``fails_above`` in force ratio and needs more iterations the larger the step."""

    line_search = False
    line_search_halvings = 0

    def __init__(self, fails_above=1.3):
        self.fails_above = fails_above
        self.rescued_steps = []
        self.solves = []

    def solve_step(self, state, force):
        ratio = force / state.force if state.force > 0 else 1.0
        if ratio > self.fails_above and state.force >= 1.0:
            raise ConvergenceError("synthetic: no convergence")
        self.solves.append(force)
        return _State(force, np.array([0.01 * math.sqrt(force)]),
                      iterations=3 + int(100 * math.log(max(ratio, 1.0))),
                      plastic_dissipation=1e-3 * max(force - 1.0, 0.0) ** 2,
                      work=1e-2 * force ** 1.5)

    def contact_radius(self, state):
        return 1e-3 * math.sqrt(state.force)


def test_sub_steps_end_on_the_requested_forces_and_a_failed_solve_is_cut():
    control = _control(yield_force=1.0)
    control.log_ratio = math.log(1.5)  # larger than the solver can take: cut
    solver = _Solver(fails_above=1.3)
    state = _State(0.0, np.zeros(1))
    ends = []
    for target in (0.5, 2.0, 3.0, 6.0, 2.0):
        state = fem_run._advance_adaptive(solver, state, target, len(ends) + 1, control)
        ends.append(state.force)
    assert ends == [0.5, 2.0, 3.0, 6.0, 2.0]  # the recorded forces are the requested ones
    assert 1.0 in solver.solves  # elastic to the first-yield force first
    assert control.failed >= 1
    loading = [f for f in solver.solves if f >= 1.0][:-1]
    ratios = np.array(loading[1:]) / np.array(loading[:-1])
    assert np.all(ratios <= 1.3)
    assert control.solves == len(solver.solves)
    record = control.summary(5)
    assert record["control"] == "adaptive" and record["failed_solves"] == control.failed
    assert record["largest_loading_ratio_above_yield"] <= 1.3
    # a solver that never converges: the step is cut until the rescue mode takes over
    stuck = _Solver(fails_above=1.0)
    control = _control(yield_force=1.0)
    with pytest.raises(ConvergenceError):
        fem_run._advance_adaptive(stuck, _State(2.0, np.zeros(1)), 3.0, 1, control)
    assert control.failed == fem_run.MAX_CUTBACKS + 1
    assert control.log_ratio == pytest.approx(
        math.log(ADAPTIVE_FIRST_RATIO) * ADAPTIVE_CUT ** fem_run.MAX_CUTBACKS, rel=0.1)


class _DentSolver(_Solver):
    """A reload over a flattened dent: the edge sweeps back (a ~ F^(1/2)) while the plastic flow
    goes on at a trickle (the plastic bound never binds)."""

    def solve_step(self, state, force):
        done = super().solve_step(state, force)
        return dataclasses.replace(done, plastic_dissipation=1.0 + 1e-9 * force,
                                   work=10.0 + force)


_DENT_ELEMENT = 1e-5  # fine surface elements: the edge bound binds


def _reload(step_control, envelope, start, target):
    """A reload over the dent (``_DentSolver``) from ``start`` to ``target`` under
    ``step_control``: the forces of its solves and what set each next step."""
    solver = _DentSolver(fails_above=10.0)
    control = AdaptiveSteps(1.0, YIELD_STRAIN, np.arange(0.0, 0.05, _DENT_ELEMENT),
                            math.log(ADAPTIVE_MAX_RATIO), step_control)
    control.log_ratio = math.log(1.02)
    state = _State(start, np.array([0.01 * math.sqrt(start)]), plastic_dissipation=1.0,
                   work=10.0 + start)
    done = fem_run._advance_adaptive(solver, state, target, 1, control, envelope)
    assert done.force == target
    return solver.solves, control.limited_by


def test_the_envelope_control_lets_a_reload_over_the_dent_through_and_loads_fresh_surface_alike():
    """Below the largest force reached (the envelope), "envelope" counts only the edge's
    advance beyond the largest contact radius reached: a reload over the dent is not cut by the
    edge bound, which cuts the same reload under "dissipation" into solves of a tenth of an
    element's advance; from the envelope on, the two take the same solves."""
    reload = _reload
    # the envelope: F and a at the largest step end, D and W where the reload began
    top = fem_run.Envelope(100.0, 1e-3 * math.sqrt(100.0), 1.0, 12.0)
    old, old_by = reload("dissipation", None, 2.0, 50.0)
    new, new_by = reload("envelope", top, 2.0, 50.0)
    assert old_by["edge"] > 0.5 * len(old) and new_by["edge"] == 0
    assert len(new) < len(old) / 4
    # a new peak: from the envelope on, the same solves (and the same as without an envelope)
    assert reload("envelope", top, 100.0, 300.0)[0] == reload("dissipation", None, 100.0,
                                                               300.0)[0]
    # the reload's own plastic flow: bounded against the dissipation since the reload began,
    # not against the run's (first loading's, 100 times larger), which never binds
    class Reyielding(_DentSolver):
        def solve_step(self, state, force):
            done = super().solve_step(state, force)
            return dataclasses.replace(done, plastic_dissipation=1000.0 + 0.5 * force)

    def plastic_steps(step_control, envelope):
        control = AdaptiveSteps(1.0, YIELD_STRAIN, np.arange(0.0, 0.05, 1e-2),
                                math.log(ADAPTIVE_MAX_RATIO), step_control)
        state = _State(20.0, np.array([0.01 * math.sqrt(20.0)]), plastic_dissipation=1010.0,
                       work=30.0)
        fem_run._advance_adaptive(Reyielding(fails_above=10.0), state, 90.0, 1, control,
                                  envelope)
        return control.limited_by["plastic"]

    began = fem_run.Envelope(100.0, 1e-3 * math.sqrt(100.0), 1010.0, 30.0)
    assert plastic_steps("dissipation", None) == 0 and plastic_steps("envelope", began) > 0
    # a reload past the envelope counts the edge's advance beyond it
    past, past_by = reload("envelope", top, 50.0, 300.0)
    assert past_by["edge"] > 0 and len(past) > len(reload("envelope", top, 50.0, 100.0)[0])


def test_the_envelope_control_resolves_the_rim_of_the_dent_as_dissipation_does():
    """Within ENVELOPE_RIM_ELEMENTS surface elements of the envelope's contact radius (the
    dent's rim, where a shakedown cycle re-yields) the edge bound counts the edge's whole
    advance, as "dissipation" does: a reload to the envelope's peak crosses the rim in solves
    of at most about an element's advance each, and the dent inside it in far fewer solves than
    "dissipation" takes there."""
    top = fem_run.Envelope(100.0, 1e-3 * math.sqrt(100.0), 1.0, 12.0)
    rim = top.radius - fem_run.ENVELOPE_RIM_ELEMENTS * _DENT_ELEMENT

    def solves(step_control, envelope):
        radii = 1e-3 * np.sqrt(_reload(step_control, envelope, 2.0, 100.0)[0])  # _DentSolver's a
        return int(np.sum(radii < rim)), int(np.sum(radii >= rim))

    inside, on_rim = solves("envelope", top)
    inside_dissipation, on_rim_dissipation = solves("dissipation", None)
    assert fem_run.ENVELOPE_RIM_ELEMENTS >= 1.0
    assert on_rim >= fem_run.ENVELOPE_RIM_ELEMENTS  # at most ~1 element per accepted solve
    assert on_rim >= 0.5 * on_rim_dissipation
    assert inside < inside_dissipation / 4


def test_an_envelope_run_without_reloads_is_the_dissipation_run_and_a_cyclic_one_is_not():
    """A history that never loads again after unloading reaches nothing below its envelope, so
    "envelope" resolves to "dissipation" there (one run, one key: the ramp a branch follows, a
    level); a cyclic branch keeps "envelope" and its base is the ramp's "dissipation" run."""
    from geocontact.fem.run import _envelope
    from geocontact.fem.settings import reloads, resolved_step_control

    assert not reloads([0.0, 5.0, 10.0, 0.0]) and reloads([0.0, 5.0, 0.0, 5.0])
    assert not reloads([0.0, 5.0, 5.0, 2.0, 0.0]) and reloads([0.0, 5.0, 2.0, 2.5])
    assert resolved_step_control("envelope", [0.0, 5.0, 0.0]) == "dissipation"
    assert resolved_step_control("envelope", [0.0, 5.0, 0.0, 5.0]) == "envelope"
    assert resolved_step_control("adaptive", [0.0, 5.0, 0.0, 5.0]) == "adaptive"
    material = preset("reference")
    plain = FeRunIdentity.of(material, [0.0, 10.0, 0.0])
    assert FeRunIdentity.of(material, [0.0, 10.0, 0.0], step_control="envelope").key() \
        == plain.key()
    assert FemJob(material, (0.0, 10.0, 0.0), step_control="envelope").key() == plain.key()
    cyclic = FeRunIdentity.of_settings(material, [0.0, 5.0, 0.0, 5.0, 0.0],
                                       FeSettings(step_control="envelope"),
                                       follows=((0.0, 10.0), 3))
    assert cyclic.inputs()["step_control"] == "envelope"
    assert cyclic.base().key() == FeRunIdentity.of(material, [0.0, 10.0]).key()
    level = FeRunIdentity.of_settings(material, [0.0, 5.0, 0.0],
                                      FeSettings(step_control="envelope"),
                                      follows=((0.0, 10.0), 3))
    assert level.inputs()["step_control"] == "dissipation"
    job = FemJob(material, (0.0, 5.0, 0.0, 5.0, 0.0), step_control="envelope",
                 follows=((0.0, 10.0), 3))
    assert job.base().key() == FemJob(material, (0.0, 10.0)).key()
    # step, force, approach, radius, dissipation (pair), elastic energy, work (pair), ...
    rows = [[0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1, 5.0, 1.0, 2e-3, 2.0, 1.0, 3.0],
            [2, 0.0, 0.5, 1e-3, 2.5, 0.0, 2.5], [3, 4.0, 0.9, 1.9e-3, 2.6, 0.9, 3.6]]
    rows = [r + [0.0] * 5 for r in rows]
    control = _control(step_control="envelope")
    # the reload began at step 2 (half the pair's values: the half model's)
    assert _envelope(rows, control) == fem_run.Envelope(5.0, 2e-3, 1.25, 1.25)
    assert _envelope(rows[:3], control) == fem_run.Envelope(5.0, 2e-3, 1.25, 1.25)
    assert _envelope(rows[:2], control) == fem_run.Envelope(5.0, 2e-3, 0.0, 0.0)
    assert _envelope(rows, _control(step_control="dissipation")) is None


def test_a_coarse_run_is_converged_in_the_load_step_where_fixed_steps_are_not(tmp_path,
                                                                              monkeypatch):
    """The weak grain 0 -> 0.3 N -> 0 (F/Fy ~ 110, perfectly plastic flattening), coarse
    "yield" mesh (the control's subject; "auto" would mesh it contact-dense):
    with fixed steps (the default before) 3 and 24 requested steps per segment differ by 1.6 % in
    the peak approach; with the adaptive control by 0.27 % (0.5 % asserted), the recorded forces the
    same as the fixed control's. An interrupted adaptive run resumes to the same curve (the
    control's state is in the checkpoint)."""
    material = preset("reference-weak")
    forces = [0.0, 0.3, 0.0]

    def run(**kwargs):
        return run_history(material, forces, "coarse", write_fields=False, mesh_rule="yield",
                           **kwargs)

    def peak_approach(result):
        return result.curve["approach_m"][np.argmax(result.curve["force_N"])]

    fixed = [run(steps_per_segment=n, step_control="fixed") for n in (3, 24)]
    adaptive = [run(steps_per_segment=n, step_control="adaptive") for n in (3, 24)]
    fixed_gap = abs(peak_approach(fixed[0]) / peak_approach(fixed[1]) - 1.0)
    adaptive_gap = abs(peak_approach(adaptive[0]) / peak_approach(adaptive[1]) - 1.0)
    assert fixed_gap > 0.01 and adaptive_gap < 0.005 and adaptive_gap < fixed_gap / 4
    assert abs(adaptive[0].curve["approach_m"][-1] / adaptive[1].curve["approach_m"][-1]
               - 1.0) < 0.005  # the residual approach
    for plain, adapted in zip(fixed, adaptive, strict=True):
        np.testing.assert_array_equal(plain.curve["force_N"], adapted.curve["force_N"])
    control = adaptive[0].summary["step_control"]
    assert control["control"] == "adaptive"
    assert control["requested_steps"] == len(adaptive[0].curve["step"]) - 1
    assert control["solves"] > 2 * control["requested_steps"]
    assert control["largest_loading_ratio_above_yield"] <= ADAPTIVE_MAX_RATIO
    assert sum(control["next_step_set_by"].values()) >= control["solves"] - control[
        "requested_steps"]
    assert adaptive[0].summary["identity"]["inputs"]["step_control"] == "adaptive"

    real = fem_run._advance_adaptive

    def interrupted(solver, state, target, k, control, *envelope):
        if k == 3:
            raise KeyboardInterrupt
        return real(solver, state, target, k, control, *envelope)

    out = tmp_path / "adaptive"
    with monkeypatch.context() as m:
        m.setattr(fem_run, "_advance_adaptive", interrupted)
        with pytest.raises(KeyboardInterrupt):
            run(steps_per_segment=3, step_control="adaptive", out=out)
    resumed = run(steps_per_segment=3, step_control="adaptive", out=out, resume=True)
    for name in ("force_N", "approach_m", "plastic_dissipation_J", "iterations"):
        np.testing.assert_array_equal(resumed.curve[name], adaptive[0].curve[name], err_msg=name)
    assert resumed.summary["step_control"] == control


def test_the_step_control_is_recorded_against_its_first_default_and_refused_in_one_line(
        tmp_path, capsys):
    """An adaptive control is the default (issue 36: "dissipation"), but the identity compares
    step_control with "fixed", its default when it entered the record: a fixed-step run (every
    committed one) keeps its key, and a default job records "dissipation", so it never takes a
    fixed-step run (nor an "adaptive" one) for its own; a record without the key reads as fixed
    steps."""
    material = preset("reference")
    assert FeSettings().step_control == "dissipation"
    plain = FeRunIdentity.of(material, [0.0, 10.0])
    fixed = FeRunIdentity.of(material, [0.0, 10.0], step_control="fixed")
    assert plain.inputs()["step_control"] == "dissipation"
    assert "step_control" not in fixed.inputs() and fixed.key() != plain.key()
    assert FeSettings.of_record(fixed.inputs()).step_control == "fixed"
    assert FeSettings.of_record(plain.inputs()) == plain.settings
    assert FemJob.of_inputs(fixed.inputs()).step_control == "fixed"
    job = FemJob(material, (0.0, 10.0))
    assert job.step_control == "dissipation" and job.key() == plain.key()
    eqps = FeRunIdentity.of(material, [0.0, 10.0], step_control="adaptive")
    assert eqps.inputs()["step_control"] == "adaptive" and eqps.key() != plain.key()
    assert FemJob.of_inputs(plain.inputs()).key() == plain.key()
    assert "fixed step control" in fixed.settings.describe(10.0)
    assert not any("step control" in w for w in plain.settings.describe(10.0))
    assert "adaptive step control" in eqps.settings.describe(10.0)
    with pytest.raises(InputError, match=r"^step_control: unknown 'smart' \(allowed: fixed, "
                                         r"adaptive, dissipation, envelope\)$"):
        FeSettings(step_control="smart")
    parser = argparse.ArgumentParser()
    FeSettings.add_model_flags(parser)
    assert "step_control" not in FeSettings.model_of(parser.parse_args([]))
    assert FeSettings.model_of(parser.parse_args(["--step-control", "fixed"]))[
        "step_control"] == "fixed"
    history = tmp_path / "h.toml"
    history.write_text("[history]\nforces = [0.0, 10.0, 0.0]\n")
    code = main(["fem", "--material", "reference", "--history", str(history), "--out",
                 str(tmp_path / "x"), "--step-control", "smart"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "--step-control" in err
