"""The FE campaign: Dask runs equal direct runs, results are cached by their identity, a failed
run (any exception, a worker killed) leaves the others finished and cached."""

import os
import sys
from dataclasses import replace

import cloudpickle
import dask
import numpy as np
import pytest

import geocontact.fem.campaign as campaign
import geocontact.fem.run as fem_run
from geocontact.cli import main
from geocontact.errors import InputError
from geocontact.fem.campaign import CampaignError, FemJob, check_scheduler_address, run_campaign
from geocontact.fem.checkpoint import checkpoint_path
from geocontact.fem.identity import finished_run, load_result
from geocontact.fem.run import run_history
from geocontact.grain.material import load_material

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
NEVER_CONVERGES = 1e-300  # a Newton tolerance below round-off: the first solve fails


@pytest.fixture(scope="module")
def material():
    return load_material("reference")


def _nothing_runs(monkeypatch):
    """From now on any FE work of a campaign fails the test."""
    def boom(*args, **kwargs):
        raise AssertionError("a cached campaign ran FE work")

    monkeypatch.setattr(campaign, "_run_job", boom)
    monkeypatch.setattr(campaign, "_run_on_dask", boom)


def _cached(cache, job):
    return finished_run(cache / job.key(), job.identity())


def test_campaign_matches_direct_runs_and_caches(material, tmp_path, monkeypatch):
    jobs = [FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=4),
            FemJob(material, (0.0, 40.0, 0.0), steps_per_segment=4)]
    results = run_campaign(jobs, tmp_path / "cache", workers=2, progress=False)
    direct = run_history(material, [0.0, 40.0, 0.0], steps_per_segment=4, write_fields=False)
    assert np.allclose(results[1].curve["approach_m"], direct.curve["approach_m"], rtol=1e-10)
    assert results[0].summary["cycles"][0]["max_force_N"] == pytest.approx(20.0)
    assert results[1].summary["identity"] == direct.summary["identity"]
    # every job has its own cache entry, keyed by its identity
    assert len({j.key() for j in jobs}) == 2
    assert all(_cached(tmp_path / "cache", j) is not None for j in jobs)
    # a rerun reads every result back and runs nothing
    _nothing_runs(monkeypatch)
    again = run_campaign(jobs, tmp_path / "cache", progress=False)
    assert np.array_equal(again[0].curve["force_N"], results[0].curve["force_N"])


def test_bad_campaign_input(material, tmp_path):
    with pytest.raises(InputError, match="mesh"):
        FemJob(material, (0.0, 100.0), mesh="huge")
    with pytest.raises(InputError, match="tolerance"):
        FemJob(material, (0.0, 100.0), tolerance=0.0)
    with pytest.raises(InputError, match="no FE runs"):
        run_campaign([], tmp_path)
    (tmp_path / "broken").mkdir()
    with pytest.raises(InputError, match="unreadable"):
        load_result(tmp_path / "broken")


# --- a malformed --scheduler is an input error before any connection -----------------------
@pytest.mark.parametrize("address", ["not a url", "tcp://", "tcp://host:notaport", "tcp://host",
                                     "http://host:8786", "tcp://host:99999", "", "tcp://:8786",
                                     "tcp://host:8786/path"])
def test_malformed_scheduler_address(address, material, tmp_path, monkeypatch, capsys):
    with pytest.raises(InputError, match="^scheduler:"):
        check_scheduler_address(address)
    _nothing_runs(monkeypatch)
    with pytest.raises(InputError, match="^scheduler:"):
        run_campaign([FemJob(material, (0.0, 20.0, 0.0))], tmp_path, scheduler=address)
    for command in (["calibrate", "--material", "reference", "--out", str(tmp_path / "P.json")],
                    ["sweep", "--out", str(tmp_path / "sweep")]):
        assert main([*command, "--scheduler", address]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and err.startswith("error: --scheduler"), err
    assert not (tmp_path / "P.json").exists() and not (tmp_path / "sweep").exists()


def test_wellformed_scheduler_addresses():
    for address in ("tcp://127.0.0.1:8786", "localhost:8786", "tls://scheduler.lan:8786",
                    "tcp://[::1]:8786", "ws://host:1"):
        assert check_scheduler_address(address) == address


# --- a failed run does not stop the campaign ------------------------------------------------
def test_failed_run_leaves_the_others_cached_sequential(material, tmp_path, monkeypatch):
    good = FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=2, label="good")
    bad = FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=2, tolerance=NEVER_CONVERGES,
                 label="never converges")
    with pytest.raises(CampaignError) as info:
        run_campaign([bad, good], tmp_path, workers=1, progress=False)
    message = str(info.value)
    assert "\n" not in message and message.startswith("campaign: 1 of 2 FE runs failed")
    assert "never converges (forces 0, 20, 0 N; coarse mesh; 2 steps/segment; tolerance 1e-300;" \
        in message and "the other run is finished and cached" in message
    assert "ConvergenceError: yield probe" in message and "rerun the same command" in message
    assert [f["key"] for f in info.value.failures] == [bad.key()]
    assert _cached(tmp_path, good) is not None and _cached(tmp_path, bad) is None
    _nothing_runs(monkeypatch)
    assert run_campaign([good], tmp_path, progress=False)[0].summary["identity"]["key"] == \
        good.key()


def test_failed_run_leaves_the_others_cached_on_dask(material, tmp_path, monkeypatch):
    jobs = [FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=2, label="low"),
            FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=2, tolerance=NEVER_CONVERGES,
                   label="never converges"),
            FemJob(material, (0.0, 30.0, 0.0), steps_per_segment=2, label="high")]
    with pytest.raises(CampaignError) as info:
        run_campaign(jobs, tmp_path, workers=2, progress=False)
    message = str(info.value)
    assert "\n" not in message and message.startswith("campaign: 1 of 3 FE runs failed")
    assert "never converges (forces 0, 20, 0 N" in message and "ConvergenceError" in message
    assert "the other 2 runs are finished and cached" in message
    assert _cached(tmp_path, jobs[0]) is not None and _cached(tmp_path, jobs[2]) is not None
    _nothing_runs(monkeypatch)
    run_campaign([jobs[0], jobs[2]], tmp_path, progress=False)


def _run_job_with_faults(job, directory):
    """Stands in for campaign._run_job on the workers (shipped by value, see below): the run
    labelled "killed" kills its worker process at load step 3, "gmsh error" raises; the
    others run as usual."""
    import geocontact.fem.campaign as on_worker  # the worker's own module: not monkeypatched
    import geocontact.fem.run as fe

    if job.label == "gmsh error":
        raise RuntimeError("gmsh: simulated meshing failure\n(second line of the message)")
    if job.label == "killed":
        advance = fe._advance

        def dying(solver, state, target, step):
            if step == 3:
                os._exit(1)  # as the kernel's OOM killer would: no exception, no clean-up
            return advance(solver, state, target, step)

        fe._advance = dying
    return on_worker._run_job(job, directory)


def test_killed_worker_and_any_error_lose_nothing_finished(material, tmp_path, monkeypatch):
    jobs = [FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=2, label="finishes"),
            FemJob(material, (0.0, 25.0, 0.0), steps_per_segment=2, label="killed"),
            FemJob(material, (0.0, 30.0, 0.0), steps_per_segment=2, label="gmsh error")]
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    monkeypatch.setattr(campaign, "_run_job", _run_job_with_faults)
    try:
        # one death is enough to give up on a run (Dask's default retries it 3 times)
        with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
                pytest.raises(CampaignError) as info:
            run_campaign(jobs, tmp_path, workers=2, progress=False)
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    message = str(info.value)
    assert "\n" not in message and message.startswith("campaign: 2 of 3 FE runs failed")
    assert "killed (forces 0, 25, 0 N" in message and "KilledWorker: the worker running it died" \
        in message
    assert "gmsh error (forces 0, 30, 0 N" in message and "RuntimeError: gmsh: simulated" in message
    assert {f["name"] for f in info.value.failures} == {"killed", "gmsh error"}
    # nothing finished is lost: the run that finished is cached, the killed one keeps its steps
    assert _cached(tmp_path, jobs[0]) is not None
    with np.load(checkpoint_path(tmp_path / jobs[1].key())) as saved:
        assert int(saved["done"]) == 2
    # the rerun: the finished run from the cache, the killed one from its checkpoint
    monkeypatch.undo()
    steps = []
    advance = fem_run._advance
    monkeypatch.setattr(fem_run, "_advance", lambda solver, state, target, step: (
        steps.append(step), advance(solver, state, target, step))[1])
    again = run_campaign(jobs[:2], tmp_path, progress=False)
    assert steps and steps[0] == 3
    assert len(again[1].curve["step"]) == again[1].summary["steps"] + 1
    assert not checkpoint_path(tmp_path / jobs[1].key()).exists()


PROGRESS_RUN = {"history": ([0.0, 20.0, 0.0], "coarse"),
                "fe": {"steps_per_segment": 4, "max_step_ratio": 1.25, "step_control": "fixed"}}


def _stopped_run(material, checkpoint, monkeypatch, stop_at):
    """PROGRESS_RUN interrupted (as by Ctrl-C) while solving load step ``stop_at``: its
    checkpoint holds the steps before it."""
    advance = fem_run._advance

    def interrupted(solver, state, target, step, *goals):
        if step == stop_at:
            raise KeyboardInterrupt
        return advance(solver, state, target, step, *goals)

    monkeypatch.setattr(fem_run, "_advance", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_history(material, *PROGRESS_RUN["history"], checkpoint=checkpoint,
                    write_fields=False, **PROGRESS_RUN["fe"])
    monkeypatch.setattr(fem_run, "_advance", advance)


def test_run_progress_reads_how_far_a_run_has_come(material, tmp_path, monkeypatch):
    """campaign.run_progress from a checkpoint alone: the steps and the solves (the sub-steps of
    the step cap) done of the run's total, which the finished run's own record confirms."""
    ckpt = tmp_path / "run.checkpoint.npz"
    _stopped_run(material, ckpt, monkeypatch, 4)
    partial = campaign.run_progress(ckpt)
    whole = run_history(material, *PROGRESS_RUN["history"], checkpoint=ckpt, resume=True,
                        write_fields=False, **PROGRESS_RUN["fe"])
    record = whole.summary["step_control"]
    assert record["solves"] > whole.summary["steps"]  # the cap divided loading steps
    assert partial["step"] == 3 and partial["steps"] == whole.summary["steps"]
    assert partial["solves"] == record["solves"]
    assert 3 <= partial["solves_done"] < record["solves"]
    assert partial["force_N"] == pytest.approx(whole.curve["force_N"][3], rel=1e-12)
    assert partial["key"] == whole.summary["identity"]["key"] and partial["wall_time_s"] > 0
    finished = campaign.run_progress(ckpt)  # an explicit checkpoint stays after the run
    assert finished["step"] == finished["steps"] == whole.summary["steps"]
    assert finished["solves_done"] == record["solves"]
    line = campaign.describe_progress(partial)
    assert line.startswith(f"step 3 of {whole.summary['steps']}, {partial['solves_done']} of "
                           f"{record['solves']} solves") and "s per solve)" in line
    assert "to go" not in line  # a time left needs a rate between two reports
    earlier = {**partial, "solves_done": 1, "wall_time_s": partial["wall_time_s"] - 200.0}
    left = partial["solves"] - partial["solves_done"]
    rate = 200.0 / (partial["solves_done"] - 1)
    assert campaign.describe_progress(partial, earlier).endswith(
        f", about {campaign._duration(rate * left)} to go at the rate of its last 3 min")
    assert "to go" not in campaign.describe_progress(finished, partial)  # nothing left


def test_campaign_reports_its_runs_under_way(material, tmp_path, capsys):
    """A long run shows progress: every ``progress_every`` seconds a line per run whose
    checkpoint moved on; none with ``progress_every=None``."""
    job = FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=4, max_step_ratio=1.25,
                 label="probe")
    run_campaign([job], tmp_path / "cache", progress_every=0.02)
    lines = [line for line in capsys.readouterr().err.splitlines()
             if line.startswith("campaign: probe: step ")]
    assert lines and all(" solves (" in line and "N, " in line for line in lines)
    run_campaign([replace(job, label="again")], tmp_path / "other", progress_every=None)
    assert "campaign: again: step" not in capsys.readouterr().err


def test_campaign_does_not_report_a_run_waiting_for_a_worker(material, tmp_path, monkeypatch,
                                                            capsys):
    """A run with a checkpoint from an earlier session waits (serial campaign) while another
    runs: its checkpoint is not progress, so no line shows it until it goes on from step 3,
    and its first line then has the time left at the rate since that checkpoint."""
    waiting = FemJob(material, tuple(PROGRESS_RUN["history"][0]), PROGRESS_RUN["history"][1],
                     label="waiting", **PROGRESS_RUN["fe"])
    cache = tmp_path / "cache"
    cache.mkdir()
    _stopped_run(material, checkpoint_path(cache / waiting.key()), monkeypatch, 4)
    first = FemJob(material, (0.0, 30.0, 0.0), steps_per_segment=4, max_step_ratio=1.25,
                   label="first")
    run_campaign([first, waiting], cache, progress_every=0.02)
    err = capsys.readouterr().err
    assert "campaign: first: step " in err
    steps = [int(line.split()[3]) for line in err.splitlines()
             if line.startswith("campaign: waiting: step ")]
    assert steps and min(steps) > 3
    assert "to go at the rate" in next(line for line in err.splitlines()
                                       if line.startswith("campaign: waiting: step "))


@pytest.mark.parametrize("every", [0, -1.0, float("nan"), float("inf"), "5", True])
def test_bad_progress_interval(material, tmp_path, every):
    with pytest.raises(InputError, match=r"^progress_every: must be a number of seconds > 0"):
        run_campaign([FemJob(material, (0.0, 1.0, 0.0))], tmp_path, progress_every=every)


def test_a_second_campaign_on_the_machine_prints_no_port_warning(capfd):
    """Two campaigns at once (a calibration and its acceptance, or the universal campaign's
    processes): the second one's scheduler found Dask's default HTTP port 8787 taken and
    printed a "Port 8787 is already in use" warning. With 8787 held here, a local cluster
    starts without a word."""
    import socket
    import warnings

    from dask.distributed import Client

    from geocontact.fem.campaign import local_cluster

    holder = socket.socket()
    try:
        holder.bind(("", 8787))
        holder.listen()
    except OSError:
        pass  # something else holds it: the case under test all the same
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with local_cluster(1) as cluster, Client(cluster) as client:
                assert client.submit(sum, [1, 2]).result() == 3
                assert ":8787/" not in cluster.dashboard_link  # its HTTP server, on a free port
    finally:
        holder.close()
    err = capfd.readouterr().err
    assert "already in use" not in err, err
