"""Branches of an FE run (fem.run.run_history ``follows``): a run that takes another run's
load steps up to one of its recorded steps and goes on from there. Started from the base's
snapshot it is the same run, to the bit, as computed whole; its identity says what it follows;
a bad branch is one line; a campaign starts branches from their base's snapshots."""

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.campaign import FemJob, remove_snapshots, run_campaign, snapshots_folder
from geocontact.fem.run import run_history, snapshot_path
from geocontact.grain.material import preset

BASE = (0.0, 300.0)
# small and quick: the coarse "yield" mesh, 4 steps a segment, the default step control
SETTINGS = {"mesh": "coarse", "steps_per_segment": 4, "mesh_rule": "yield"}
STEP = 6  # a plastic step of the base (first yield is near 2 N, the base's 6th step 78 N)


@pytest.fixture(scope="module")
def material():
    return preset("reference")


@pytest.fixture(scope="module")
def base(material, tmp_path_factory):
    folder = tmp_path_factory.mktemp("snapshots")
    result = run_history(material, list(BASE), snapshots=folder, write_fields=False,
                         **SETTINGS)
    return result, folder


def _level(base_result, step=STEP):
    force = float(base_result.curve["force_N"][step])
    return [0.0, force, 0.0, force, 0.0]


def test_a_branch_from_the_snapshot_is_the_branch_computed_whole(material, base):
    result, folder = base
    assert result.summary["step_control"]["control"] == "dissipation"
    assert sorted(p.name for p in folder.iterdir())[0] == "step_00001.checkpoint.npz"
    history = _level(result)
    started = run_history(material, history, follows=(BASE, STEP), write_fields=False,
                          start=snapshot_path(folder, STEP), **SETTINGS)
    whole = run_history(material, history, follows=(BASE, STEP), write_fields=False,
                        **SETTINGS)
    assert started.summary["branch"]["started_from_base_snapshot"] is True
    assert whole.summary["branch"]["started_from_base_snapshot"] is False
    assert started.summary["identity"]["key"] == whole.summary["identity"]["key"]
    for column in started.curve:
        np.testing.assert_array_equal(started.curve[column], whole.curve[column])
    # up to the step it follows, the branch is its base
    for column in ("force_N", "approach_m", "plastic_dissipation_J", "contact_radius_m"):
        np.testing.assert_array_equal(started.curve[column][:STEP + 1],
                                      result.curve[column][:STEP + 1])
    # and then it unloads, reloads and unloads: two cycles to the step's force
    cycles = started.summary["cycles"]
    assert len(cycles) == 2 and cycles[0]["max_force_N"] == history[1]
    assert cycles[0]["residual_approach_m"] > 0.0
    # the time of a branch started from the snapshot is its own steps'
    assert started.summary["wall_time_s"] < whole.summary["wall_time_s"]


def test_the_branch_records_what_it_follows(material, base):
    result, _ = base
    history = tuple(_level(result))
    branch = FemJob(material, history, follows=(BASE, STEP), **SETTINGS)
    own = FemJob(material, history, **SETTINGS)
    inputs = branch.inputs()["inputs"]
    assert inputs["follows"] == {"forces_N": list(BASE), "step": STEP}
    assert "follows" not in own.inputs()["inputs"]  # other runs' records as they were
    assert branch.key() != own.key()
    # the branch's mesh is its base's: its mesh force is the base's top
    assert inputs["mesh_force_N"] == BASE[1] and own.inputs()["inputs"]["mesh_force_N"] < BASE[1]
    # a branch's record gives back the same job
    assert FemJob.of_inputs(inputs).key() == branch.key()
    assert branch.base().key() == FemJob(material, BASE, **SETTINGS).key()


@pytest.mark.parametrize("follows, message", [
    ((BASE, 0), "the step must be a whole number >= 1"),
    ((BASE, 2.0), "the step must be a whole number >= 1"),
    (((0.0, 100.0, 0.0), 3), "the base must be a loading ramp"),
    ((BASE,), "expected (base forces, step)"),
])
def test_a_bad_branch_is_one_line(material, follows, message):
    with pytest.raises(InputError) as caught:
        FemJob(material, (0.0, 50.0, 0.0), follows=follows, **SETTINGS)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_branch_must_go_first_to_its_steps_force(material, base):
    result, folder = base
    history = _level(result)
    with pytest.raises(InputError, match=f"the base's step {STEP} is at"):
        run_history(material, [0.0, 1.01 * history[1], 0.0], follows=(BASE, STEP),
                    write_fields=False, **SETTINGS)
    with pytest.raises(InputError, match="so no step 99"):
        run_history(material, history, follows=(BASE, 99), write_fields=False, **SETTINGS)


def test_a_snapshot_of_another_step_costs_only_the_work(material, base, capsys):
    result, folder = base
    history = _level(result)
    capsys.readouterr()
    other = run_history(material, history, follows=(BASE, STEP), write_fields=False,
                        start=snapshot_path(folder, STEP - 1), **SETTINGS)
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "not used: it is the base's step 5, not the branch's 6" in err
    assert other.summary["branch"]["started_from_base_snapshot"] is False
    whole = run_history(material, history, follows=(BASE, STEP), write_fields=False,
                        **SETTINGS)
    np.testing.assert_array_equal(other.curve["approach_m"], whole.curve["approach_m"])


def test_a_campaign_starts_branches_from_their_bases_snapshots(material, base, tmp_path):
    result, _ = base
    job = FemJob(material, tuple(_level(result)), follows=(BASE, STEP), label="level",
                 **SETTINGS)
    base_job = job.base()
    assert base_job.snapshots and base_job.follows is None
    [made] = run_campaign([base_job], tmp_path, workers=1, progress=False)
    np.testing.assert_array_equal(made.curve["approach_m"], result.curve["approach_m"])
    assert snapshot_path(snapshots_folder(tmp_path, base_job), STEP).is_file()
    [branch] = run_campaign([job], tmp_path, workers=1, progress=False)
    assert branch.summary["branch"]["started_from_base_snapshot"] is True
    # the snapshots are a saving, not a result: removed, a branch computes the base's steps
    (snapshots_folder(tmp_path, base_job) / "mine.txt").write_text("not the FE's")
    remove_snapshots(tmp_path, base_job)
    assert [p.name for p in snapshots_folder(tmp_path, base_job).iterdir()] == ["mine.txt"]
    again = run_history(material, list(job.forces), follows=job.follows, write_fields=False,
                        start=snapshot_path(snapshots_folder(tmp_path, base_job), STEP),
                        **SETTINGS)
    assert again.summary["branch"]["started_from_base_snapshot"] is False
    np.testing.assert_array_equal(again.curve["approach_m"], branch.curve["approach_m"])


def test_an_adopted_checkpoint_brings_its_snapshots(material, tmp_path):
    """A base under way when the FE code changed (to code that reproduces its runs) goes on
    from its checkpoint under the new key, and its snapshots come with it, so its branches
    start from them instead of a run of the base again."""
    import json

    from geocontact.fem.campaign import _adopt_checkpoint
    from geocontact.fem.checkpoint import checkpoint_path
    from geocontact.fem.identity import REPRODUCED_FE_CODE, fe_code_hash, identity_key

    job = FemJob(material, (0.0, 5.0), mesh="coarse", snapshots=True)
    record = job.identity().to_dict()
    record["fe_code"] = next(iter(REPRODUCED_FE_CODE[fe_code_hash()]))  # an older, reproduced
    record["key"] = identity_key(record)
    old = tmp_path / f"{record['key']}.checkpoint.npz"
    np.savez(old, identity=np.array(json.dumps(record)))
    steps = tmp_path / f"{record['key']}.steps"
    steps.mkdir()
    (steps / "step_00003.checkpoint.npz").write_bytes(b"a snapshot")
    _adopt_checkpoint(tmp_path, job, progress=False)
    assert checkpoint_path(tmp_path / job.key()).is_file() and not old.exists()
    assert (snapshots_folder(tmp_path, job) / "step_00003.checkpoint.npz").read_bytes() \
        == b"a snapshot"
    assert not steps.exists()


def test_the_snapshots_of_a_finished_base_are_found_under_an_older_key(material, tmp_path):
    """A base finished (and its snapshots saved) under FE code that the current code
    reproduces: its branches start from those snapshots (the folder renamed to the base's key
    now), not from a run of the base again; another run's snapshots are left alone."""
    import json

    from geocontact.fem.campaign import adopt_snapshots
    from geocontact.fem.identity import REPRODUCED_FE_CODE, fe_code_hash, identity_key

    job = FemJob(material, (0.0, 5.0), mesh="coarse", snapshots=True)

    def saved(forces):
        record = FemJob(material, forces, mesh="coarse").identity().to_dict()
        record["fe_code"] = next(iter(REPRODUCED_FE_CODE[fe_code_hash()]))
        record["key"] = identity_key(record)
        folder = tmp_path / f"{record['key']}.steps"
        folder.mkdir()
        np.savez(folder / "step_00002.checkpoint.npz", identity=np.array(json.dumps(record)))
        return folder

    other, same = saved((0.0, 6.0)), saved((0.0, 5.0))
    assert adopt_snapshots(tmp_path, job) == snapshots_folder(tmp_path, job)
    assert (snapshots_folder(tmp_path, job) / "step_00002.checkpoint.npz").is_file()
    assert not same.exists() and other.is_dir()
