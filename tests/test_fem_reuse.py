"""When an FE result may be reused (fem.reuse): one identity for the cache, the checkpoint and
``--resume``; a resumed run writes what an uninterrupted one writes; a bad checkpoint costs a
fresh start, never a traceback."""

import json
from dataclasses import replace

import meshio
import numpy as np
import pytest
from conftest import YIELD_FIXED

import geocontact.fem.identity as reuse
import geocontact.fem.run as fem_run
from geocontact.analyses.cycles import run_cycles
from geocontact.fem.campaign import FemJob
from geocontact.fem.checkpoint import checkpoint_path, pending_fields_path
from geocontact.fem.identity import LIBRARIES, FeRunIdentity, fe_code_hash, finished_run
from geocontact.fem.result import STEPS_PER_SEGMENT
from geocontact.fem.run import run_history
from geocontact.grain.material import MATERIAL_KEYS, preset

FORCES = [0.0, 60.0, 0.0]
STEPS = 3  # 10 load steps; waypoints (ParaView files) at steps 7 and 10
# the step accounting above is the fixed control's on the "yield" mesh (conftest.YIELD_FIXED, the
# defaults before issue 36; the adaptive control numbers its solves): named where a test counts
# the steps


@pytest.fixture(scope="module")
def material():
    return preset("reference")


def _run(material, out=None, **kwargs):
    return run_history(material, FORCES, mesh="coarse", steps_per_segment=STEPS, out=out,
                       **{**YIELD_FIXED, **kwargs})


def _interrupt_at(monkeypatch, step):
    """Make the FE stop with KeyboardInterrupt when it starts load step ``step``."""
    real = fem_run._advance

    def advance(solver, state, target, k):
        if k == step:
            raise KeyboardInterrupt
        return real(solver, state, target, k)

    monkeypatch.setattr(fem_run, "_advance", advance)


def _interrupted_run(monkeypatch, material, out, step=9, **kwargs):
    """Start a run into ``out`` and stop it at load step ``step`` (its checkpoint stays)."""
    with monkeypatch.context() as m:
        _interrupt_at(m, step)
        with pytest.raises(KeyboardInterrupt):
            _run(material, out, **kwargs)


def _count_steps(monkeypatch):
    """Count the load steps the FE solves from now on."""
    real, calls = fem_run._advance, []

    def advance(solver, state, target, k):
        calls.append(k)
        return real(solver, state, target, k)

    monkeypatch.setattr(fem_run, "_advance", advance)
    return calls


def _files(directory):
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


# --- A: one identity ---------------------------------------------------------------------------
def test_key_changes_with_every_input_and_library(material, monkeypatch):
    base = FemJob(material, (0.0, 100.0, 0.0))
    key = base.key()
    # other spellings of the same run: same key (defaults resolved, the label is a name)
    assert FemJob(material, (0, 100, 0)).key() == key
    assert FemJob(material, (0.0, 100.0, 0.0), steps_per_segment=STEPS_PER_SEGMENT["coarse"],
                  mesh_force=100.0, label="another name").key() == key
    variants = {
        "forces": FemJob(material, (0.0, 101.0, 0.0)),
        "history shape": FemJob(material, (0.0, 100.0, 0.0, 100.0, 0.0)),
        "mesh": FemJob(material, (0.0, 100.0, 0.0), mesh="default"),
        "steps_per_segment": FemJob(material, (0.0, 100.0, 0.0), steps_per_segment=5),
        "tolerance": FemJob(material, (0.0, 100.0, 0.0), tolerance=1e-9),
        "volumetric": FemJob(material, (0.0, 100.0, 0.0), volumetric="full"),
        "mesh_force": FemJob(material, (0.0, 100.0, 0.0), mesh_force=200.0),
        "kinematics": FemJob(material, (0.0, 100.0, 0.0), kinematics="finite"),
        "mesh_rule": FemJob(material, (0.0, 100.0, 0.0), mesh_rule="contact"),
        "step_rule": FemJob(material, (0.0, 100.0, 0.0), step_rule="decade"),
    }
    for name in (*MATERIAL_KEYS, "radius"):
        value = getattr(material, name)
        variants[name] = FemJob(replace(material, **{name: value * 1.01 if value else 0.01}),
                                (0.0, 100.0, 0.0))
    keys = {name: job.key() for name, job in variants.items()}
    assert key not in keys.values()
    assert len(set(keys.values())) == len(keys)
    # the FE source and every library's version: monkeypatch where the key reads them
    with monkeypatch.context() as m:
        m.setattr(reuse, "fe_code_hash", lambda: "other FE code")
        assert base.key() != key
    real = reuse.distribution_version
    for library in LIBRARIES:
        with monkeypatch.context() as m:
            m.setattr(reuse, "distribution_version",
                      lambda name, lib=library: real(name) + ("+other" if name == lib else ""))
            assert base.key() != key, library
    assert base.key() == key


def test_a_grain_yielding_at_the_contact_edge_records_how_its_first_yield_is_found(material):
    """Above the critical friction angle (49.06 deg at nu = 0.25, grain.hertz) the first yield is
    located by elastic solves, with the yield ratio on the surface at the contact edge (issue 36):
    the identity says so, so runs of the earlier detectors are not reused; below it the inputs
    and the key are those of before (no such entry)."""
    edge = replace(material, friction_angle_deg=55.0)
    below = replace(material, friction_angle_deg=45.0)
    assert FeRunIdentity.of(edge, FORCES, "coarse").inputs()["first_yield"] == (
        reuse.EDGE_FIRST_YIELD)
    for grain in (material, below):
        assert "first_yield" not in FeRunIdentity.of(grain, FORCES, "coarse").inputs()


def test_summary_records_the_identity_and_fields_progress_do_not_change_it(material, tmp_path):
    quiet = _run(material, tmp_path / "a", write_fields=False, progress=False)
    loud = _run(material, tmp_path / "b", write_fields=True, progress=True)
    job = FemJob(material, tuple(FORCES), steps_per_segment=STEPS, **YIELD_FIXED)
    assert quiet.summary["identity"] == loud.summary["identity"]
    identity = json.loads((tmp_path / "b" / "summary.json").read_text())["identity"]
    assert identity["key"] == job.key() == FeRunIdentity.of(
        material, FORCES, "coarse", steps_per_segment=STEPS, **YIELD_FIXED).key()
    assert identity["inputs"] == loud.summary["inputs"]
    assert identity["fe_code"] == fe_code_hash()
    assert set(identity["libraries"]) == set(LIBRARIES)
    assert all(v and v != "absent" for v in identity["libraries"].values())
    np.testing.assert_array_equal(quiet.curve["approach_m"], loud.curve["approach_m"])
    # a run written without fields does not stand in for one that needs them
    assert finished_run(tmp_path / "a", job.identity()) is not None
    assert finished_run(tmp_path / "a", job.identity(), fields=True) is None
    assert finished_run(tmp_path / "b", job.identity(), fields=True) is not None


def test_cycles_resume_reuses_only_a_run_of_the_same_code(material, tmp_path, monkeypatch,
                                                          capsys):
    out = tmp_path / "cycles"
    first = run_cycles(material, FORCES, out, mesh="coarse",
                       steps_per_segment=STEPS, **YIELD_FIXED)
    steps = _count_steps(monkeypatch)
    again = run_cycles(material, FORCES, out, mesh="coarse",
                       steps_per_segment=STEPS, **YIELD_FIXED,
                       resume=True)
    assert steps == [] and again["analyses"]["fe"] == first["analyses"]["fe"]
    # the FE run was made by other (older) code: --resume runs it again
    summary_path = out / "fe" / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["identity"]["fe_code"] = "0123456789abcdef"
    summary_path.write_text(json.dumps(summary))
    # as that code would have written it: a whole result, its manifest holding this summary (an
    # edited result is the user's and is refused, issue 39)
    from geocontact.files import add_to_manifest

    add_to_manifest(out, ["fe/summary.json"])
    capsys.readouterr()
    run_cycles(material, FORCES, out, mesh="coarse",
                       steps_per_segment=STEPS, **YIELD_FIXED, resume=True)
    assert len(steps) == 10
    assert "made by other FE code" in capsys.readouterr().err
    assert json.loads(summary_path.read_text())["identity"]["fe_code"] == fe_code_hash()


# --- B: a resumed run writes the same files ------------------------------------------------
def test_resumed_run_writes_the_files_of_an_uninterrupted_one(material, tmp_path, monkeypatch):
    whole = tmp_path / "whole"
    full = _run(material, whole)
    out = tmp_path / "resumed"
    with monkeypatch.context() as m:
        _interrupt_at(m, 9)  # after the peak waypoint (step 7), before the end (step 10)
        with pytest.raises(KeyboardInterrupt):
            _run(material, out)
    assert not out.exists() and checkpoint_path(out).exists()
    assert _files(pending_fields_path(out)) == ["step_00007.vtu"]
    steps = _count_steps(monkeypatch)
    resumed = _run(material, out, resume=True)
    assert steps == [9, 10]
    assert _files(out) == _files(whole) == [".geocontact-result.json", "curve.csv", "fields",
                                            "fields/step_00007.vtu", "fields/step_00010.vtu",
                                            "summary.json"]
    assert (out / "curve.csv").read_text() == (whole / "curve.csv").read_text()
    for column in ("force_N", "approach_m", "plastic_dissipation_J", "elastic_energy_J"):
        np.testing.assert_array_equal(resumed.curve[column], full.curve[column])
    for name in ("step_00007.vtu", "step_00010.vtu"):
        a, b = meshio.read(out / "fields" / name), meshio.read(whole / "fields" / name)
        np.testing.assert_array_equal(a.point_data["displacement"],
                                      b.point_data["displacement"])
        for key in ("eqps", "mises", "yield_state"):
            np.testing.assert_array_equal(a.cell_data[key][0], b.cell_data[key][0])
    # nothing left beside the result
    assert sorted(p.name for p in tmp_path.iterdir()) == ["resumed", "whole"]


def test_resume_with_fields_from_a_checkpoint_without_them_starts_afresh(material, tmp_path,
                                                                        monkeypatch, capsys):
    out = tmp_path / "run"
    with monkeypatch.context() as m:
        _interrupt_at(m, 9)
        with pytest.raises(KeyboardInterrupt):
            _run(material, out, write_fields=False)
    capsys.readouterr()
    _run(material, out, resume=True)
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "lacks the ParaView fields" in err
    assert _files(out / "fields") == ["step_00007.vtu", "step_00010.vtu"]


# --- C: a bad checkpoint is one line and a fresh start -------------------------------------
@pytest.fixture(scope="module")
def good_checkpoint(material, tmp_path_factory):
    """The bytes of a real checkpoint after 5 of the 10 steps."""
    out = tmp_path_factory.mktemp("checkpoint") / "run"
    real = fem_run._advance

    def advance(solver, state, target, k):
        if k == 6:
            raise KeyboardInterrupt
        return real(solver, state, target, k)

    fem_run._advance = advance
    try:
        with pytest.raises(KeyboardInterrupt):
            _run(material, out, write_fields=False)
    finally:
        fem_run._advance = real
    return checkpoint_path(out).read_bytes()


@pytest.fixture(scope="module")
def uninterrupted(material):
    return _run(material, write_fields=False)


def _corrupt(kind, good, path):
    with np.load(path.parent / "good.npz") as data:
        saved = {k: data[k] for k in data.files}
    if kind == "truncated":
        path.write_bytes(good[: len(good) // 2])
    elif kind == "missing keys":
        np.savez(path, **{k: v for k, v in saved.items() if not k.startswith("state_")})
    elif kind == "old format":  # the format before fem.reuse: a 16-hex signature
        old = {k: v for k, v in saved.items() if k not in ("identity", "format", "fields")}
        np.savez(path, signature=np.array("0123456789abcdef"), **old)
    elif kind == "signature not JSON":
        np.savez(path, **{**saved, "identity": np.array([1, 2, 3])})
    elif kind == "signature a bare hash":
        np.savez(path, **{**saved, "identity": np.array('"0123456789abcdef"')})
    elif kind == "other inputs":
        record = json.loads(str(saved["identity"]))
        record["inputs"]["forces_N"] = [0.0, 61.0, 0.0]
        np.savez(path, **{**saved, "identity": np.array(json.dumps(record))})
    elif kind == "inconsistent rows":
        np.savez(path, **{**saved, "rows": saved["rows"][:-2]})


@pytest.mark.parametrize("kind, reason", [
    ("truncated", "unreadable"), ("missing keys", "unreadable"),
    ("old format", "old checkpoint format"), ("signature not JSON", "unreadable"),
    ("signature a bare hash", "older FE"),
    ("other inputs", "other inputs (forces_N)"), ("inconsistent rows", "unreadable"),
])
def test_bad_checkpoint_is_one_line_and_a_fresh_start(kind, reason, material, good_checkpoint,
                                                      uninterrupted, tmp_path, capsys):
    out = tmp_path / "run"
    (tmp_path / "good.npz").write_bytes(good_checkpoint)
    path = checkpoint_path(out)
    _corrupt(kind, good_checkpoint, path)
    capsys.readouterr()
    result = _run(material, out, resume=True, write_fields=False)
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err, err
    assert err.startswith(f"warning: checkpoint {path} not used") and reason in err, err
    assert err.endswith("starting afresh")
    np.testing.assert_array_equal(result.curve["approach_m"], uninterrupted.curve["approach_m"])
    assert not path.exists() and (out / "summary.json").exists()


def test_good_checkpoint_is_resumed(material, good_checkpoint, uninterrupted, tmp_path,
                                    monkeypatch, capsys):
    out = tmp_path / "run"
    checkpoint_path(out).write_bytes(good_checkpoint)
    steps = _count_steps(monkeypatch)
    result = _run(material, out, resume=True, write_fields=False)
    assert steps == [6, 7, 8, 9, 10] and capsys.readouterr().err == ""
    np.testing.assert_array_equal(result.curve["approach_m"], uninterrupted.curve["approach_m"])


def test_finite_strain_run_resumes_to_the_uninterrupted_result(material, tmp_path, monkeypatch):
    """The checkpoint of a finite-strain run carries its state (Kirchhoff stress, C_p^-1 - I):
    a resumed run ends where an uninterrupted one does; a small-strain checkpoint is not taken
    for it (other identity)."""
    whole = _run(material, kinematics="finite", write_fields=False)
    out = tmp_path / "finite"
    _interrupted_run(monkeypatch, material, out, kinematics="finite", write_fields=False)
    assert checkpoint_path(out).exists()
    steps = _count_steps(monkeypatch)
    resumed = _run(material, out, resume=True, kinematics="finite", write_fields=False)
    assert steps == [9, 10]
    for column in ("force_N", "approach_m", "plastic_dissipation_J", "elastic_energy_J"):
        np.testing.assert_array_equal(resumed.curve[column], whole.curve[column])
    assert resumed.summary["identity"]["inputs"]["kinematics"] == "finite"
    # a small-strain checkpoint does not stand in for a finite-strain run
    other = tmp_path / "small"
    _interrupted_run(monkeypatch, material, other, write_fields=False)
    steps.clear()
    _run(material, other, resume=True, kinematics="finite", write_fields=False)
    assert steps[0] == 1


def test_a_run_whose_inputs_agree_to_rounding_is_reused_by_a_campaign(material, tmp_path,
                                                                      monkeypatch, capsys):
    """The same campaign's inputs computed on another CPU can differ in the last bit (numpy's
    SIMD log/exp): the committed run is reused, not recomputed; a real change of an input, a
    hand-edited record or a run outside the folder of its key is not reused."""
    import math

    from geocontact.fem.campaign import run_campaign

    cache = tmp_path / "cache"
    job = FemJob(material, tuple(FORCES), mesh="coarse", steps_per_segment=STEPS)
    [first] = run_campaign([job], cache, workers=1, progress=False)
    peak = math.nextafter(FORCES[1], math.inf)  # one ulp up
    near = FemJob(material, (0.0, peak, 0.0), mesh="coarse", steps_per_segment=STEPS)
    assert near.key() != job.key()
    assert reuse.difference(first.summary["identity"], near.identity(), rounding=True) is None
    assert reuse.difference(first.summary["identity"], near.identity()) is not None
    started = []
    monkeypatch.setattr("geocontact.fem.campaign._run_job",
                        lambda *a, **k: started.append(a) or first)
    [again] = run_campaign([near], cache, workers=1, progress=True)
    assert started == [] and again.curve["force_N"].tolist() == first.curve["force_N"].tolist()
    assert f"reusing {job.key()}" in capsys.readouterr().err
    # a real change of the inputs (1e-9 in force) is another run
    other = FemJob(material, (0.0, FORCES[1] * (1 + 1e-9), 0.0), mesh="coarse",
                   steps_per_segment=STEPS)
    assert reuse.equivalent_run(cache, other.identity()) is None
    # a hand-edited record (its key no longer the hash of the rest) is not trusted
    summary_path = cache / job.key() / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["identity"]["inputs"]["tolerance"] *= 1 + 1e-14
    summary_path.write_text(json.dumps(summary))
    assert reuse.equivalent_run(cache, near.identity()) is None


def test_runs_and_checkpoints_of_reproduced_fe_code_are_used(material, tmp_path, monkeypatch,
                                                             capsys):
    """After a change of the FE sources listed in ``REPRODUCED_FE_CODE`` (it leaves every
    finished run as it was), the older code's finished runs are reused and its checkpoints
    resumed, by a campaign; without the entry, or with an entry of other sources, they are
    stale."""
    from geocontact.fem.campaign import run_campaign

    cache = tmp_path / "cache"
    job = FemJob(material, tuple(FORCES), mesh="coarse", steps_per_segment=STEPS)
    [first] = run_campaign([job], cache, workers=1, progress=False)
    old_code, old_key = fe_code_hash(), job.key()
    # a run under way of the older code: interrupted at step 9, its checkpoint in the cache
    other = FemJob(material, (0.0, 40.0, 0.0), mesh="coarse", steps_per_segment=STEPS)
    with monkeypatch.context() as m:
        _interrupt_at(m, 9)
        with pytest.raises(KeyboardInterrupt):
            run_history(material, list(other.forces), mesh="coarse", steps_per_segment=STEPS,
                        out=cache / other.key(), write_fields=False)
    assert checkpoint_path(cache / other.key()).exists()
    uninterrupted = run_history(material, list(other.forces), mesh="coarse",
                                steps_per_segment=STEPS, write_fields=False)

    new_code = "0123456789abcdef"
    monkeypatch.setattr(reuse, "fe_code_hash", lambda: new_code)
    monkeypatch.setattr("geocontact.fem.campaign.fe_code_hash", lambda: new_code)
    assert job.key() != old_key
    for table in ({}, {"fedcba9876543210": {old_code: "another change"}}):
        monkeypatch.setattr(reuse, "REPRODUCED_FE_CODE", table)
        assert reuse.equivalent_run(cache, job.identity()) is None
        assert reuse.difference(first.summary["identity"], job.identity(),
                                rounding=True) == "made by other FE code"
    monkeypatch.setattr(reuse, "REPRODUCED_FE_CODE", {new_code: {old_code: "a test change"}})
    assert reuse.equivalent_run(cache, job.identity())[1] == old_key
    found = reuse.cached_run(cache, job.identity())  # what the analyses and scripts look up
    assert reuse.run_key(found, job.identity()) == old_key != job.key()
    capsys.readouterr()
    steps = _count_steps(monkeypatch)
    [again, resumed] = run_campaign([job, other], cache, workers=1, progress=True)
    err = capsys.readouterr().err
    assert f"reusing {old_key}" in err and f"made by FE code {old_code}" in err
    assert "going on from the checkpoint" in err
    assert steps[0] == 9  # the run under way went on where it stopped
    assert again.curve["force_N"].tolist() == first.curve["force_N"].tolist()
    for name, values in uninterrupted.curve.items():
        np.testing.assert_array_equal(values, resumed.curve[name], err_msg=name)
    assert resumed.summary["identity"]["fe_code"] == new_code


def test_the_fe_hash_reads_the_code_not_its_place_comments_or_docstrings():
    """``code_fingerprint``: moving a module (its imports renamed), a comment or a docstring
    leaves the FE hash as it is; a changed number or operator changes it."""
    from geocontact.fem.identity import code_fingerprint

    before = ('"""Doc."""\nfrom ..material import Material\n\n\ndef f(x):\n'
              '    """Old doc."""\n    from .. import resolution\n    return 2.0 * x  # pair\n')
    moved = ('"""Another doc."""\nfrom ..grain.material import Material\n\n\ndef f(x):\n'
             '    from ..fem import roundoff as resolution\n    return 2.0 * x\n')
    assert code_fingerprint(before) == code_fingerprint(moved)
    assert code_fingerprint(before) != code_fingerprint(before.replace("2.0 * x", "2.0 + x"))
    assert code_fingerprint(before) != code_fingerprint(before.replace("2.0", "2.5"))


def test_the_moved_sources_reproduce_the_runs_of_record():
    """The current FE hash lists the hash of record (209c6c5f6f7c038c, every committed finite-
    strain run) as reproduced: the modules moved in issue 38 with their syntax trees unchanged."""
    from geocontact.fem.identity import REPRODUCED_FE_CODE

    assert "209c6c5f6f7c038c" in REPRODUCED_FE_CODE[fe_code_hash()]


def test_a_run_whose_fully_plastic_onset_came_off_a_reload_is_not_reused():
    """FE code before 4a1e7207570fa809 read Fp on any step of rising force, a reload below the
    envelope too: such a run is not reused; an onset on virgin loading (or none) is."""
    from geocontact.fem.identity import _onset_off_virgin_loading
    from geocontact.fem.result import FemResult

    force = np.array([0.0, 5.0, 10.0, 0.0, 0.3, 10.0, 0.0])

    def result(bracket):
        return FemResult(curve={"force_N": force}, summary={"fully_plastic_bracket_N": bracket})

    assert _onset_off_virgin_loading(result([0.0, 0.3]))
    assert not _onset_off_virgin_loading(result([5.0, 10.0]))  # step 2: virgin
    assert not _onset_off_virgin_loading(result(None))


def test_an_entry_may_leave_out_the_runs_of_one_setting():
    """The envelope control's second form reproduces every run of its first but those of the
    envelope control (REPRODUCED_UNLESS), and through it the older codes' runs."""
    from geocontact.fem.identity import reproduced_code

    first = "b91341923e5d4e1f"
    assert reproduced_code(first, {"step_control": "dissipation"}) is not None
    assert reproduced_code(first, {"step_control": "envelope"}) is None
    assert reproduced_code(first) is None  # without the inputs: not known to be reproduced
    assert reproduced_code("4aeedf54d2157bf5", {"step_control": "dissipation"}) is not None
    assert reproduced_code("4aeedf54d2157bf5") is not None  # it knew no envelope control
