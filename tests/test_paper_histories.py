"""The paper-findings table on synthetic runs whose verdicts are known (no FE)."""

import json
from pathlib import Path

import numpy as np
import pytest

from geocontact.analyses import cycles as cy
from geocontact.analyses.paper_histories import EXTRA_TOLERANCES, PaperRun, paper_findings, study
from geocontact.errors import InputError, run_reporting_errors
from geocontact.grain.force_history import preset_history
from geocontact.grain.material import preset


def synthetic_run(name, history, material, increments, plastic_work, stiffening=0.0):
    """A run whose cycles have the given residual increments and plastic work, with a curve:
    each loading branch F = Fmax ((d - d0)/(dmax - d0))^1.5 from the previous residual
    approach d0; the elastic range dmax - d0 shrinks by ``stiffening`` per cycle after the
    first, and, for a given prior peak, with the prior peak (a stiffer reload)."""
    forces = preset_history(history, 3000.0)
    peaks = forces[1::2]
    d, f, cycles, steps = [0.0], [0.0], [], [0]
    residual = 0.0
    for k, (peak, inc, wp) in enumerate(zip(peaks, increments, plastic_work, strict=True)):
        start = residual
        prior = max(peaks[:k], default=0.0)
        span = 2e-5 * (peak / 3000.0) ** (2 / 3) * (1.0 - stiffening * k) / (1 + prior / 3000)
        if k == 0:
            span *= 3.0  # the virgin loading is the softest
        dmax = start + span
        t = np.linspace(0, 1, 21)[1:]
        d += list(start + t * span)
        f += list(peak * t**1.5)
        residual = start + inc
        d += list(dmax + t * (residual - dmax))
        f += list(peak * (1 - t) ** 1.5)
        steps.append(len(d) - 1)
        cycles.append({"max_force_N": peak, "max_approach_m": dmax,
                       "residual_approach_m": residual, "plastic_work_J": wp,
                       "steps": [steps[-2], steps[-1]]})
    curve = {"step": np.arange(len(d)), "force_N": np.array(f), "approach_m": np.array(d)}
    return PaperRun(name=name, material_name=material, material=preset(material), history=history,
                    forces=forces, curve=curve, summary={"cycles": cycles},
                    analysis=cy.analyse(cycles, source=name),
                    extra={t: cy.analyse(cycles, tolerance=t, source=name)
                           for t in EXTRA_TOLERANCES})


def decay(first, c, p, n):
    return [first] + [first * c * k ** (-p) for k in range(2, n + 1)]


@pytest.fixture
def paper_like():
    """Runs that behave as the paper says: 1 MPa and DP shake down later than 10 MPa and vM."""
    return {
        "repeated-10MPa": synthetic_run("repeated-10MPa", "repeated", "reference",
                                        decay(1e-4, 0.25, 1.5, 10), decay(0.1, 0.25, 1.5, 10),
                                        stiffening=0.004),
        "repeated-1MPa": synthetic_run("repeated-1MPa", "repeated", "reference-weak",
                                       decay(1e-3, 0.2, 1.2, 10), decay(1.0, 0.2, 1.2, 10),
                                       stiffening=0.001),
        "mono-decreasing-10MPa": synthetic_run("mono-decreasing-10MPa", "mono-decreasing",
                                               "reference", [1e-4] + [1e-7] * 6,
                                               [0.1] + [2e-4] * 6),
        "mono-decreasing-1MPa": synthetic_run("mono-decreasing-1MPa", "mono-decreasing",
                                              "reference-weak", [1e-3] + [1e-7] * 6,
                                              [1.0] + [2e-4] * 6),
        "mono-increasing-10MPa": synthetic_run("mono-increasing-10MPa", "mono-increasing",
                                               "reference", [1e-6 * k for k in range(1, 8)],
                                               [1e-3 * k for k in range(1, 8)]),
        "repeated-von-mises-10MPa": synthetic_run("repeated-von-mises-10MPa", "repeated",
                                                  "reference-von-mises",
                                                  decay(1e-4, 0.05, 3.0, 10),
                                                  decay(0.1, 0.05, 3.0, 10)),
    }


def by_statement(rows, start):
    matches = [r for r in rows if r["statement"].startswith(start)]
    assert len(matches) == 1, start
    return matches[0]


def test_findings_agree_on_paper_like_runs(paper_like):
    rows = paper_findings(paper_like)
    assert by_statement(rows, "Hysteresis")["agrees"] is True
    assert by_statement(rows, "Repeated loading ends in elastic shakedown")["agrees"] is True
    stronger = by_statement(rows, "The stronger sphere")
    assert stronger["agrees"] is True
    # 0.25 N^-1.5 < 0.01 from N = ceil(25^(2/3) = 8.55); 0.2 N^-1.2 from ceil(20^(1/1.2) = 12.2)
    assert stronger["our_value"]["10MPa"] == 9 and stronger["our_value"]["1MPa"] == 13
    nc10 = by_statement(rows, "Critical cycle Nc (repeated-10MPa)")
    assert nc10["agrees"] is True and nc10["paper_value"] == [11, 11]
    assert by_statement(rows, "Critical cycle Nc (repeated-1MPa)")["agrees"] is True
    assert by_statement(rows, "Reloading curves are stiffer")["agrees"] is True
    assert by_statement(rows, "Subsequent curves are stiffer")["agrees"] is True
    dec = by_statement(rows, "Monotonically decreasing loading (10MPa)")
    assert dec["agrees"] is True
    assert dec["our_value"]["plastic_work"] == pytest.approx(6 * 2e-4 / 0.1)
    assert dec["our_value"]["residual"] == pytest.approx(6e-7 / 1e-4)
    assert by_statement(rows, "Under decreasing loading")["agrees"] is True
    assert by_statement(rows, "No shakedown under monotonically increasing loading "
                              "(mono-increasing-10MPa)")["agrees"] is True
    assert by_statement(rows, "Drucker-Prager grains need more cycles")["agrees"] is True


def test_findings_disagree_when_the_data_say_otherwise(paper_like):
    runs = dict(paper_like)
    # swap: the von Mises run now shakes down later than the Drucker-Prager one
    runs["repeated-von-mises-10MPa"] = synthetic_run(
        "repeated-von-mises-10MPa", "repeated", "reference-von-mises",
        decay(1e-4, 0.9, 0.5, 10), decay(0.1, 0.9, 0.5, 10))
    # a repeated run that ratchets for ever
    runs["repeated-1MPa"] = synthetic_run("repeated-1MPa", "repeated", "reference-weak",
                                          [1e-3] + [5e-5] * 9, [1.0] + [0.3] * 9)
    rows = paper_findings(runs)
    assert by_statement(rows, "Drucker-Prager grains need more cycles")["agrees"] is False
    assert by_statement(rows, "Repeated loading ends in elastic shakedown")["agrees"] is False
    assert by_statement(rows, "Hysteresis")["agrees"] is False  # ratios do not keep falling


def test_findings_without_runs_say_so(paper_like):
    runs = {k: v for k, v in paper_like.items() if k != "repeated-von-mises-10MPa"}
    rows = paper_findings(runs)
    vm = by_statement(rows, "Drucker-Prager grains need more cycles")
    assert vm["agrees"] is None and vm["our_value"].startswith("not available")
    inc1 = by_statement(rows, "No shakedown under monotonically increasing loading "
                              "(mono-increasing-1MPa)")
    assert inc1["agrees"] is None
    single = by_statement(rows, "Monotonically increasing loading (mono-increasing-10MPa): "
                                "residual approach per cycle")
    assert single["agrees"] is None and "single loads" in single["our_value"]


def with_single_loads(run, residual_factor, work_factor):
    """``run`` with single loads to each of its peaks: cycle k of the history has
    ``residual_factor`` x the single load's residual approach and ``work_factor`` x its plastic
    work (cycle 1 is the single load itself)."""
    rows = []
    for k, c in enumerate(run.analysis.cycles):
        rf, wf = (1.0, 1.0) if k == 0 else (residual_factor, work_factor)
        rows.append({"peak_force_N": c["max_force_N"] * (1 + 1e-6),
                     "residual_approach_m": c["residual_approach_m"] / rf,
                     "plastic_work_J": c["plastic_work_J"] / wf})
    run.single_loads = rows
    return run


@pytest.mark.parametrize("residual_factor, work_factor, agrees", [
    (1.03, 0.4, True),    # the paper: residual a little larger, plastic work lower
    (0.97, 0.4, False),   # residual smaller than a single load's
    (1.5, 0.4, False),    # residual much larger: not "a little"
    (1.03, 1.2, False),   # plastic work per cycle above the single load's
])
def test_increasing_history_against_single_loads(paper_like, residual_factor, work_factor,
                                                 agrees):
    name = "mono-increasing-10MPa"
    runs = dict(paper_like)
    runs[name] = with_single_loads(paper_like[name], residual_factor, work_factor)
    row = by_statement(paper_findings(runs), f"Monotonically increasing loading ({name}): "
                                             "residual approach per cycle")
    assert row["agrees"] is agrees
    value = row["our_value"]
    assert value["residual_ratio_by_cycle"][0] == pytest.approx(1.0)
    assert value["residual_ratio_by_cycle"][1:] == pytest.approx([residual_factor] * 6)
    assert value["plastic_work_ratio_by_cycle"][1:] == pytest.approx([work_factor] * 6)


def test_study_lists_the_paper_histories():
    s = study()
    assert {r["history"] for r in s["runs"].values()} == {"repeated", "mono-decreasing",
                                                           "mono-increasing"}
    assert {r["material"] for r in s["runs"].values()} == {"reference", "reference-weak",
                                                            "reference-von-mises"}
    vm = preset("reference-von-mises")
    ref = preset("reference")
    assert vm.friction_angle_deg == 0.0
    assert vm.with_(friction_angle_deg=ref.friction_angle_deg) == ref  # same strength otherwise


def test_report_shows_the_findings_table(paper_like, tmp_path):
    from geocontact.cli import main
    from geocontact.files import write_json_atomic

    rows = paper_findings(paper_like)
    write_json_atomic(tmp_path / "paper" / "findings.json", {"findings": rows})
    assert main(["report", str(tmp_path / "paper")]) == 0
    html = (tmp_path / "paper" / "report.html").read_text()
    assert "findings on loading histories" in html
    assert html.count("<td>agrees</td>") == sum(r["agrees"] is True for r in rows)
    assert "Drucker-Prager grains need more cycles" in html


def test_each_finding_reads_as_one_sentence_with_its_deciding_numbers(paper_like, tmp_path):
    """Issue 38: the report's findings table gives one sentence per statement with the numbers
    that decide it, not the analysis' dictionaries (those stay in findings.json / .csv)."""
    from geocontact.cli import main
    from geocontact.files import write_json_atomic

    rows = [r for r in paper_findings(paper_like) if not r.get("missing_runs")]
    assert rows
    for row in rows:
        sentence = row["finding"]
        assert "{" not in sentence and "': " not in sentence, sentence
        assert not any(key in sentence for key in ("_N", "fitted_tol", "residual_cycle2",
                                                   "prior_peak_N", "largest_later")), sentence
        assert any(ch.isdigit() for ch in sentence) or "shakedown" in sentence, sentence
    weakens = next(r for r in rows if r["statement"].startswith("Hysteresis"))
    largest = weakens["our_value"]["repeated-10MPa"]["largest_later"]
    assert f"{largest:.3g} (10 MPa)" in weakens["finding"]
    write_json_atomic(tmp_path / "paper" / "findings.json", {"findings": rows})
    assert main(["report", str(tmp_path / "paper")]) == 0
    html = (tmp_path / "paper" / "report.html").read_text()
    assert "what we find" in html and "plastic_work: " not in html and "cycle: " not in html


def test_write_study_writes_every_result_file(paper_like, tmp_path):
    from geocontact.analyses.paper_histories import write_study

    findings, files = write_study(tmp_path / "study", paper_like, {"command": "test"})
    assert sorted(files) == sorted([f"{n}.json" for n in paper_like]
                                   + ["cycles.csv", "findings.json", "findings.csv"])
    assert all((tmp_path / "study" / f).is_file() for f in files)
    saved = json.loads((tmp_path / "study" / "findings.json").read_text())
    assert saved["findings"] == json.loads(json.dumps(findings))
    assert saved["runs"] == list(paper_like) and saved["provenance"] == {"command": "test"}


def test_increments_at_the_fe_resolution_mean_immediate_shakedown(paper_like):
    """A 1 MPa run whose residual increments after cycle 1 are round-off (signs flipping at
    1e-6 of cycle 1, as in the default-mesh FE run) shakes down at once: it neither decays
    slower nor ratchets longer than the 10 MPa run, whatever power a fit to the noise gives."""
    runs = dict(paper_like)
    noise = [1e-3] + [3e-9 * (-1) ** k for k in range(9)]
    runs["repeated-1MPa"] = synthetic_run("repeated-1MPa", "repeated", "reference-weak", noise,
                                          decay(1.0, 0.001, 1.4, 10))
    rows = paper_findings(runs)
    assert by_statement(rows, "The stronger sphere")["agrees"] is False
    longer = by_statement(rows, "The weaker sphere (1 MPa) ratchets longer")
    assert longer["agrees"] is False
    assert longer["our_value"]["ratchetting_cycles"] == {"repeated-10MPa": 9, "repeated-1MPa": 0}


def test_report_leaves_out_statements_whose_runs_are_missing(paper_like, tmp_path):
    """A study of some of the runs (as the demo's): the report's table holds only what those
    runs decide, and one line names the runs (and the command) the other statements need."""
    from geocontact.analyses.paper_histories import write_study
    from geocontact.files import provenance
    from geocontact.report import build_report

    runs = {k: v for k, v in paper_like.items() if k.endswith("10MPa")}
    write_study(tmp_path, runs, provenance("test", {}))
    findings = json.loads((tmp_path / "findings.json").read_text())["findings"]
    missing = [f for f in findings if f.get("missing_runs")]
    assert missing and all(set(f["missing_runs"]) - set(runs) for f in missing)
    text = build_report(tmp_path).read_text()
    assert "not available" not in text and "n/a" not in text
    assert f"{len(missing)} more of the paper's statements need runs" in text
    assert "repeated-1MPa" in text and "geocontact study paper-histories" in text


def test_fe_model_reaches_every_run_of_the_study():
    """--kinematics/--mesh-rule/--step-rule/--max-step-ratio of `study paper-histories` reach
    every history run and the single loads beside the mono-increasing ones (their cache keys
    differ from the default model's)."""
    from geocontact.analyses.paper_histories import single_load_jobs, study_jobs

    model = {"kinematics": "finite", "mesh_rule": "contact", "step_rule": "segment",
             "max_step_ratio": 1.01}
    plan, jobs = study_jobs("coarse", only=["repeated-1MPa", "mono-increasing-1MPa"],
                            fe_model=model)
    _, plain = study_jobs("coarse", only=["repeated-1MPa", "mono-increasing-1MPa"])
    singles = single_load_jobs(jobs[1])
    assert [label for label, _, _ in plan] == ["repeated-1MPa", "mono-increasing-1MPa"]
    assert len(singles) == 7  # the peaks of the mono-increasing history, 100 -> 3000 N
    for job in jobs + singles:
        assert {key: getattr(job, key) for key in model} == model
    assert {j.key() for j in jobs}.isdisjoint(j.key() for j in plain)


# The weak grain's FE of record (examples/params-reference-weak.json; docs/cycles.md) and the
# study run with it.
# Fixed load steps (cut at x1.01), named: the control the study's committed runs were made with,
# whatever the default (issue 36 made the adaptive control the default); the other materials'
# runs on the "yield" meshes (--others-mesh-rule yield), the rule before "auto" became the default.
WEAK_FE_MODEL = {"kinematics": "finite", "mesh_rule": "contact", "max_step_ratio": 1.01,
                 "step_control": "fixed"}
FINITE_STUDY_RUNS = (Path(__file__).resolve().parents[1] / "datasets" / "fe-runs"
                     / "paper-histories-finite")


def test_fe_model_can_be_kept_to_the_weak_grain(tmp_path, capsys):
    """--fe-model-materials reference-weak: finite strain for the weak grain's runs (and the
    single loads of its increasing history) only; the σc = 10 MPa and von Mises runs keep the FE
    defaults, the same jobs (cache keys) as a study without the FE model flags; the step control
    alone reaches every run. An unknown preset is a one-line error naming the option and the
    allowed presets."""
    from geocontact.analyses.paper_histories import single_load_jobs, study_jobs

    model = {k: v for k, v in WEAK_FE_MODEL.items() if k != "step_control"}
    names = ["repeated-10MPa", "mono-increasing-1MPa", "repeated-von-mises-10MPa"]
    plan, jobs = study_jobs("coarse", only=names, fe_model=model,
                            fe_model_materials=["reference-weak"])
    _, plain = study_jobs("coarse", only=names)
    _, finite = study_jobs("coarse", only=names, fe_model=model)
    by_name = {label: job for (label, _, _), job in zip(plan, jobs, strict=True)}
    assert by_name["repeated-10MPa"].key() == plain[0].key()
    assert by_name["repeated-von-mises-10MPa"].key() == plain[2].key()
    assert by_name["mono-increasing-1MPa"].key() == finite[1].key()
    for job in single_load_jobs(by_name["mono-increasing-1MPa"]):
        assert job.kinematics == "finite" and job.max_step_ratio == 1.01
    # the step control alone reaches every run: fixed steps (the committed study's) against
    # the default, the dissipation-bounded adaptive control
    _, fixed = study_jobs("coarse", only=names, fe_model={**model, "step_control": "fixed"},
                          fe_model_materials=["reference-weak"])
    assert [job.step_control for job in fixed] == ["fixed"] * 3
    assert [job.step_control for job in plain] == ["dissipation"] * 3
    assert [job.kinematics for job in fixed] == ["small", "finite", "small"]
    assert fixed[0].key() != plain[0].key()
    assert [job.step_control for job in study_jobs("coarse", only=names, fe_model=WEAK_FE_MODEL,
                                                   fe_model_materials=["reference-weak"])[1]
            ] == ["fixed"] * 3
    with pytest.raises(InputError, match=r"fe_model_materials: unknown material 'weak' "
                                         r"\(allowed: .*reference-weak"):
        study_jobs("coarse", only=names, fe_model=model, fe_model_materials=["weak"])

    root = Path(__file__).resolve().parents[1]
    script = _paper_histories_script(root)
    code = run_reporting_errors(lambda: script.main(
        ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache"), "--kinematics",
         "finite", "--fe-model-materials", "weak"]))
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --fe-model-materials: unknown material 'weak'")
    assert err.count("\n") == 1
    assert not (tmp_path / "out").exists()  # refused before any FE run or output


def test_findings_with_the_weak_grains_fe_of_record(tmp_path):
    """docs/cycles.md, "Findings with the weak grain's FE of record": the study on the committed
    runs of datasets/fe-runs/paper-histories-finite (no FE run; the weak grain with finite
    strain, the others small strain). With finite strain the weak grain ratchets slowly under
    repeated loading to the same peak, which turns two of the paper's statements from "no"
    (small strain, session 3) to "yes", shakes down at once under decreasing loading, and does
    not shake down under increasing loading, where the residual approach after each peak is
    that of a single load to it (to 0.16 %), not "a little larger"."""
    root = Path(__file__).resolve().parents[1]
    script = _paper_histories_script(root)
    out = tmp_path / "study"
    assert script.main(["--mesh", "default", "--kinematics", "finite", "--mesh-rule", "contact",
                        "--max-step-ratio", "1.01", "--step-control", "fixed",
                        "--fe-model-materials", "reference-weak", "--others-mesh-rule", "yield",
                        "--workers", "1", "--cache",
                        str(FINITE_STUDY_RUNS),
                        "--out", str(out)]) == 0  # the whole study: every run finished
    found = {f["statement"]: f for f in json.loads((out / "findings.json").read_text())["findings"]}

    def finding(start):
        (match,) = [f for s, f in found.items() if s.startswith(start)]
        return match

    longer = finding("The weaker sphere (1 MPa) ratchets longer")
    assert longer["agrees"] is True  # small strain: no (0 cycles against 7)
    assert longer["our_value"]["ratchetting_cycles"] == {"repeated-10MPa": 7, "repeated-1MPa": 9}
    assert longer["our_value"]["last_ratio"]["repeated-1MPa"] == pytest.approx(1.22e-3, rel=0.01)
    faster = finding("The stronger sphere (sigma_c = 10 MPa) shakes down in fewer cycles")
    assert faster["agrees"] is True  # small strain: no
    assert faster["our_value"]["1MPa"] is None  # no critical cycle: it does not decay
    nc = finding("Critical cycle Nc (repeated-1MPa)")
    assert nc["agrees"] is False and nc["our_value"]["fitted"]["residual"] is None
    decreasing = finding("Monotonically decreasing loading (1MPa)")
    assert decreasing["agrees"] is True
    assert 0 < decreasing["our_value"]["plastic_work"] < 5e-4  # 0.023 % of cycle 1
    assert abs(decreasing["our_value"]["residual"]) < 1e-4
    assert finding("Under decreasing loading the weaker sphere")["agrees"] is True
    stiffer = finding("Subsequent curves are stiffer")
    assert stiffer["agrees"] is False
    assert stiffer["our_value"]["repeated-1MPa"]["last_over_cycle2"] < 1.0  # the ratchet's share
    assert finding("Repeated loading ends in elastic shakedown")["agrees"] is True  # at 1 %
    rising = finding("No shakedown under monotonically increasing loading (mono-increasing-1MPa)")
    assert rising["agrees"] is True and rising["our_value"]["state"] == "ratchetting"
    assert rising["our_value"]["last_residual_increment_ratio"] == pytest.approx(6.23, rel=0.01)
    single = finding("Monotonically increasing loading (mono-increasing-1MPa)")
    assert single["agrees"] is False  # the residual half: equal, not "a little larger"
    residual = single["our_value"]["residual_ratio_by_cycle"]
    work = single["our_value"]["plastic_work_ratio_by_cycle"]
    assert residual[0] == pytest.approx(1.0, abs=1e-9) and work[0] == pytest.approx(1.0, abs=1e-9)
    assert all(0.998 < r < 1.0 for r in residual[1:])  # 0.9985-0.9998: equal to 0.16 %
    assert work[1:] == sorted(work[1:], reverse=True) and 0.3 < work[-1] < work[1] < 1.0
    # the runs of the other materials are the small-strain ones of docs/cycles.md's session 3
    runs = {name: json.loads((out / f"{name}.json").read_text()) for name in study()["runs"]}
    assert runs["repeated-10MPa"]["fe"]["inputs"].get("kinematics", "small") == "small"
    assert runs["repeated-1MPa"]["fe"]["inputs"]["kinematics"] == "finite"


def _paper_histories_script(root):
    """The module of ``geocontact study paper-histories``."""
    from geocontact.cli.study import paper_histories

    return paper_histories


def test_report_draws_every_historys_cycles_against_its_first(paper_like, tmp_path):
    """The report's figure of the study: cycle N over cycle 1 for each history from cycles.csv,
    the values that a log axis can show (positive, above round-off) and only those."""
    import csv

    from geocontact.analyses.paper_histories import write_study
    from geocontact.calibrate.cyclic_fit import ROUND_OFF
    from geocontact.files import provenance
    from geocontact.report import build_report

    write_study(tmp_path, paper_like, provenance("test", {}))
    text = build_report(tmp_path).read_text()
    assert "Every history&#x27;s cycles against its first" in text  # the figure's caption
    with (tmp_path / "figures" / "paper_histories_ratios.csv").open(newline="") as handle:
        drawn = list(csv.DictReader(handle))
    for name, run in paper_like.items():
        for key in ("residual_increment_ratio", "plastic_work_ratio"):
            expected = [(c["cycle"], c[key]) for c in run.analysis.cycles
                        if c["cycle"] >= 2 and c[key] is not None and c[key] > ROUND_OFF]
            got = [(int(float(row[f"{name}_{key}_cycle"])), float(row[f"{name}_{key}"]))
                   for row in drawn if row.get(f"{name}_{key}", "") != ""]
            assert [c for c, _ in got] == [c for c, _ in expected]
            assert [v for _, v in got] == pytest.approx([v for _, v in expected], rel=1e-12)


@pytest.mark.parametrize("text", ["source,cycle\nrepeated-1MPa,2\n",
                                  "source,cycle,residual_increment_ratio,plastic_work_ratio\n"
                                  "repeated-1MPa,two,0.1,0.1\n"])
def test_report_refuses_a_malformed_cycles_csv(paper_like, tmp_path, text):
    """A hand-edited cycles.csv (a column missing, a cell not a number) is a one-line error
    naming the file, never a traceback."""
    from geocontact.analyses.paper_histories import write_study
    from geocontact.errors import InputError
    from geocontact.files import provenance
    from geocontact.report import build_report

    write_study(tmp_path, paper_like, provenance("test", {}))
    (tmp_path / "cycles.csv").write_text(text)
    with pytest.raises(InputError, match=r"cycles\.csv: malformed") as info:
        build_report(tmp_path)
    assert "\n" not in str(info.value)


def test_increasing_history_starts_with_the_single_load_to_its_first_peak():
    """The weak grain's increasing history (finite strain, committed in
    datasets/fe-runs/paper-histories-finite) and its single load to 100 N share the mesh (sized
    for 3000 N) and the load steps, so the history's first cycle is that single load: the same
    forces, approach and plastic dissipation to round-off (1e-10 of the peak values measured),
    and the history then goes on to its six higher peaks."""
    from geocontact.analyses.paper_histories import single_load_jobs, study_jobs
    from geocontact.fem.identity import cached_run

    cache = FINITE_STUDY_RUNS
    _, (history,) = study_jobs("default", only=["mono-increasing-1MPa"], fe_model=WEAK_FE_MODEL,
                               fe_model_materials=["reference-weak"])
    first = single_load_jobs(history)[0]
    assert first.forces == (0.0, 100.0, 0.0) and first.mesh_force == 3000.0
    # both committed and current (by key, or made by FE code the current code reproduces)
    whole = cached_run(cache, history.identity())
    single = cached_run(cache, first.identity())
    assert whole is not None and single is not None
    n = len(single.curve["force_N"])
    assert len(whole.curve["force_N"]) > n
    np.testing.assert_array_equal(whole.curve["force_N"][:n], single.curve["force_N"])
    for column in ("approach_m", "plastic_dissipation_J", "contact_radius_m"):
        scale = np.max(np.abs(single.curve[column]))
        np.testing.assert_allclose(whole.curve[column][:n], single.curve[column],
                                   rtol=0, atol=1e-8 * scale, err_msg=column)
    assert [c["max_force_N"] for c in whole.summary["cycles"]] == pytest.approx(
        [100.0 + k * 2900.0 / 6 for k in range(7)], rel=1e-12)
