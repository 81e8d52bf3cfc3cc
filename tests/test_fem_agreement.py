"""The agreement rule (fem.identity.AGREED_FE_CODE): a job on the compiled kernels, the node
contact's default, reuses a committed run made by the numpy path of an FE code the compiled
kernels are shown to reproduce within a stated tolerance, and says so; nothing else is reused
under it (another input, a code not in the table, a checkpoint, the numpy path's own jobs)."""

import json
import shutil
from pathlib import Path

import pytest

import geocontact.fem.identity as reuse
from geocontact.fem.campaign import FemJob, run_campaign
from geocontact.fem.identity import (
    AGREED_FE_CODE,
    Agreement,
    compiled_code_hash,
    fe_code_hash,
    load_result,
)
from geocontact.fem.result import TOLERANCE

ROOT = Path(__file__).resolve().parent.parent
DATASETS = ROOT / "datasets" / "fe-runs"
# the cheapest committed runs, made by the numpy path of FE code 209c6c5f6f7c038c: a small-strain
# run of the paper's histories and the finite-strain weak pilot's level 1
COMMITTED = DATASETS / "paper-histories-finite" / "90e8165604bc6e8dfa7c"
COMMITTED_CODE = "209c6c5f6f7c038c"
EVIDENCE = "docs/verification/fe-kernels-agreement.json"
# the engine of the reruns after fe-solver's merge (FE code, compiled code: fe-kernels-agreement)
MERGED_ENGINE = ("82eb800afc111cfd", "61cf57a372a3c19d")


def evidence_problems(engine: tuple[str, str], rule: Agreement, runs: list[dict]) -> list[str]:
    """What the evidence rows ``runs`` lack for an entry of ``engine`` (FE code, compiled code):
    rows made again under that code, small and finite strain among them, each within the
    tolerance with the same Newton iterations."""
    fe_code, compiled_code = engine
    rows = [r for r in runs if r.get("fe_code") == fe_code
            and r.get("compiled_code") == compiled_code]
    problems = [f"{r['key']}: not within {rule.tolerance:g}" for r in rows
                if not (r.get("agrees") and r["largest_difference"] <= rule.tolerance
                        and r["newton_iterations"][0] == r["newton_iterations"][1])]
    kinematics = {load_result(DATASETS / r["campaign"] / r["key"]).summary["identity"][
        "inputs"].get("kinematics", "small") for r in rows}
    if kinematics != {"small", "finite"}:
        problems.append(f"reruns of {sorted(kinematics)} strain only")
    return problems


ENTRIES = [(engine, older, rule) for engine, olders in AGREED_FE_CODE.items()
           for older, rule in olders.items()]


def test_the_current_engine_agrees_with_the_committed_runs():
    """The compiled kernels are the node contact's default, so the engine of today (FE code,
    compiled code) has its entry, covering the numpy runs of its own FE code and of the FE code
    that made the committed runs (each entry checked below)."""
    olders = AGREED_FE_CODE.get((fe_code_hash(), compiled_code_hash()))
    assert olders is not None and fe_code_hash() in olders and COMMITTED_CODE in olders


@pytest.mark.parametrize("engine, older, rule", ENTRIES,
                         ids=[f"{e[0]}-{e[1]}-{o}" for e, o, _ in ENTRIES])
def test_every_agreement_states_its_tolerance_and_evidence(engine, older, rule):
    """Each entry has a tolerance below the Newton tolerance and a file of reruns in the
    repository under that engine's code, small and finite strain among them, each within the
    tolerance with the same Newton iterations."""
    assert isinstance(rule, Agreement) and 0.0 < rule.tolerance < TOLERANCE
    runs = json.loads((ROOT / rule.evidence).read_text())["runs"]
    assert evidence_problems(engine, rule, runs) == []


def test_the_evidence_check_finds_what_an_entry_lacks():
    """The check of the entries above, on the committed evidence: the compiled path as merged
    with fe-solver (``MERGED_ENGINE``) reruns the small-strain runs within 1e-10 but not the
    finite-strain one (reuse_factor's inexact solves); all-agreeing rows pass, and rows of one
    kinematics only do not."""
    rule = Agreement(why="a test", tolerance=1e-10, evidence=EVIDENCE)
    runs = json.loads((ROOT / EVIDENCE).read_text())["runs"]
    today = MERGED_ENGINE
    rows = [r for r in runs if (r.get("fe_code"), r.get("compiled_code")) == today]
    problems = evidence_problems(today, rule, runs)
    assert rows and problems
    assert any("bcc780af7852ba2948b6: not within" in p for p in problems)
    agreeing = [{**r, "agrees": True, "largest_difference": 1e-12} for r in rows]
    assert evidence_problems(today, rule, agreeing) == []
    small_only = [r for r in agreeing if r["key"] != "bcc780af7852ba2948b6"]
    assert evidence_problems(today, rule, small_only) == ["reruns of ['small'] strain only"]


@pytest.mark.parametrize("keywords, field", [
    ({"tolerance": 1e-8}, "tolerance"), ({"tolerance": 0.0}, "tolerance"),
    ({"tolerance": None}, "tolerance"), ({"evidence": ""}, "evidence"),
    ({"evidence": None}, "evidence"),
])
def test_an_agreement_without_a_tolerance_or_evidence_is_refused(keywords, field):
    good = {"why": "a test", "tolerance": 1e-10, "evidence": "docs/verification/x.json"}
    Agreement(**good)
    with pytest.raises(ValueError, match=f"^Agreement.{field}"):
        Agreement(**{**good, **keywords})


@pytest.fixture()
def cache(tmp_path):
    """A cache holding one committed numpy run, as a campaign with --cache datasets/... has."""
    folder = tmp_path / "cache"
    shutil.copytree(COMMITTED, folder / COMMITTED.name)
    return folder


def _committed_job(**changes) -> FemJob:
    return FemJob.of_inputs(load_result(COMMITTED).summary["identity"]["inputs"], **changes)


def test_a_default_job_reuses_a_committed_numpy_run_under_the_agreement(cache, monkeypatch,
                                                                        capsys):
    """The committed run's job at today's defaults (the compiled kernels) is not run again: the
    campaign and cached_run find the numpy run, say so on stderr, and the result records the
    rule; the run's folder stays as it was made. The same job with --kernels numpy finds it
    as the same run, bit for bit."""
    job = _committed_job()
    assert job.settings().kernels == "compiled" and "kernels" not in job.inputs()["inputs"]
    assert job.key() != COMMITTED.name
    before = (cache / COMMITTED.name / "summary.json").read_bytes()
    monkeypatch.setattr("geocontact.fem.campaign._run_job", _must_not_run)
    [result] = run_campaign([job], cache, workers=1, progress=True)
    err = capsys.readouterr().err
    assert (f"reusing {COMMITTED.name}, made by the numpy path of FE code {COMMITTED_CODE}"
            in err and "within 1e-10 relative" in err and "cached, 0 to run" in err)
    reused = result.summary["reused"]
    assert reused["key"] == COMMITTED.name and reused["for"]["key"] == job.key()
    assert reused["made_by"] == {"fe_code": COMMITTED_CODE, "kernels": "numpy"}
    assert reused["for"]["compiled_code"] == compiled_code_hash()
    assert reused["tolerance"] == 1e-10 and (ROOT / reused["evidence"]).is_file()
    assert result.curve["force_N"].tolist() == load_result(COMMITTED).curve["force_N"].tolist()
    assert (cache / COMMITTED.name / "summary.json").read_bytes() == before
    assert reuse.cached_run(cache, job.identity()).summary["reused"]["key"] == COMMITTED.name
    assert "made by the numpy path" in capsys.readouterr().err
    # the override finds the same run bit for bit: no agreement involved
    numpy_job = _committed_job(kernels="numpy")
    assert numpy_job.inputs()["inputs"]["kernels"] == "numpy"
    found, key = reuse.equivalent_run(cache, numpy_job.identity())
    assert key == COMMITTED.name and "reused" not in found.summary


def _must_not_run(*args, **kwargs):
    raise AssertionError("the FE ran: the committed run was not reused")


@pytest.mark.parametrize("changes", [
    {"mesh_rule": "contact"}, {"tolerance": 2e-8}, {"steps_per_segment": 13},
    {"kinematics": "finite"}, {"max_step_ratio": 1.5},
])
def test_no_agreement_when_another_input_differs(cache, changes):
    assert reuse.equivalent_run(cache, _committed_job(**changes).identity()) is None


def test_no_agreement_for_a_code_not_in_the_table(cache, monkeypatch):
    """Without the committed code's entry, or with an entry for another engine only, the
    default job is a new run; the bit-for-bit rule still finds the run for --kernels numpy."""
    job = _committed_job()
    current = (fe_code_hash(), compiled_code_hash())
    without = {current: {code: rule for code, rule in AGREED_FE_CODE[current].items()
                         if code != COMMITTED_CODE}}
    other_engine = {(fe_code_hash(), "0" * 16): AGREED_FE_CODE[current]}
    for table in ({}, without, other_engine):
        monkeypatch.setattr(reuse, "AGREED_FE_CODE", table)
        assert reuse.equivalent_run(cache, job.identity()) is None
        assert reuse.equivalent_run(cache, _committed_job(kernels="numpy").identity())
    # nor under another compiled code (an edit of the kernels)
    monkeypatch.undo()
    monkeypatch.setattr(reuse, "compiled_code_hash", lambda: "1" * 16)
    assert reuse.equivalent_run(cache, job.identity()) is None


def test_the_agreement_is_one_way_and_not_for_checkpoints():
    """A numpy job does not take a compiled run under the rule (the evidence is of compiled
    reruns of numpy runs, and --kernels numpy asks for the numpy path); a checkpoint (the
    campaign's ``difference(..., rounding=True)``) is never adopted under it."""
    numpy_record = load_result(COMMITTED).summary["identity"]
    job = _committed_job()
    compiled_record = job.inputs()
    assert reuse.reuse_rule(numpy_record, compiled_record, agreement=True) == "agreed"
    assert reuse.reuse_rule(numpy_record, compiled_record) is None
    numpy_job = _committed_job(kernels="numpy").inputs()
    assert reuse.reuse_rule(compiled_record, numpy_job, agreement=True) is None
    assert reuse.reuse_rule(numpy_record, numpy_job) == "reproduced"
    assert reuse.difference(numpy_record, job.identity(), rounding=True) is not None
    assert reuse.difference(numpy_record, job.identity(), rounding=True, agreement=True) is None


def test_a_record_says_which_kernels_made_it():
    """``recorded_kernels``: the inputs' kernels where recorded (numpy with the node contact,
    since the compiled default), else compiled with a compiled_code (a default node-contact
    run), else numpy (every run before the compiled default, and the facet contact's)."""
    numpy_record = load_result(COMMITTED).summary["identity"]
    assert reuse.recorded_kernels(numpy_record) == "numpy"
    assert reuse.recorded_kernels(_committed_job().inputs()) == "compiled"
    assert reuse.recorded_kernels(_committed_job(kernels="numpy").inputs()) == "numpy"
    bare = {**numpy_record, "compiled_code": compiled_code_hash()}
    assert reuse.recorded_kernels(bare) == "compiled"


CAMPAIGNS = sorted(p for p in DATASETS.iterdir() if p.is_dir())


@pytest.mark.parametrize("campaign", CAMPAIGNS, ids=[p.name for p in CAMPAIGNS])
def test_every_committed_run_is_found_by_its_job_at_todays_defaults(campaign):
    """The job of each committed run's recorded inputs, with today's defaults for what the
    record leaves out (the compiled kernels with the node contact, numpy with the facet
    contact), finds a committed run of the same inputs in its campaign: nothing is recomputed."""
    recorded = reuse.recorded_identities(campaign)
    assert recorded
    for folder, record in recorded:
        if (reuse.recorded_kernels(record) == "compiled"
                and record.get("compiled_code") != compiled_code_hash()):
            continue  # made by other compiled kernels: stale before the default too
        identity = FemJob.of_inputs(record["inputs"]).identity()
        found = reuse.equivalent_run(campaign, identity, recorded)
        assert found is not None, folder.name
        assert reuse.same_to_rounding(found[0].summary["identity"]["inputs"], record["inputs"])


def test_every_committed_staircase_run_stands_for_its_job_at_todays_defaults():
    """datasets/staircase (folders named by their settings, read by scripts/measure_staircase.py):
    each finished run stands for its job at today's defaults, node and facet contact alike."""
    summaries = sorted((ROOT / "datasets" / "staircase").glob("*/summary.json"))
    assert summaries
    for summary in summaries:
        record = json.loads(summary.read_text())["identity"]
        job = FemJob.of_inputs(record["inputs"])
        assert reuse.difference(record, job.identity(), rounding=True,
                                agreement=True) is None, summary.parent.name
