"""Nothing lost, nothing stale: result folders are never a user's folder, land whole, survive an
interrupt between renames, sweep what dead writers left, and SIGTERM exits cleanly."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import geocontact.files as gio
from geocontact.cli import main
from geocontact.errors import InputError
from geocontact.files import (
    RESULT_MANIFEST,
    atomic_directory,
    check_replaceable,
    read_manifest,
    sweep_temporaries,
    verify_manifest,
)

HISTORY = "[history]\nforces = [0, 60, 0]\n"


def _dead_pid() -> int:
    """The PID of a process that has exited (so no writer of that PID is alive)."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def _write(path: Path, name: str, text: str = "x") -> None:
    with atomic_directory(path, name) as tmp:
        (tmp / "result.txt").write_text(text)
        (tmp / "sub").mkdir()
        (tmp / "sub" / "more.txt").write_text(text)


# --- the rule ------------------------------------------------------------------------------------
def test_a_users_folder_is_refused_and_kept(tmp_path):
    user = tmp_path / "mydir"
    user.mkdir()
    (user / "notes.txt").write_text("my thesis")
    with pytest.raises(InputError, match=r"out: .*mydir exists and is not a geocontact result"):
        _write(user, "fem")
    assert (user / "notes.txt").read_text() == "my thesis"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mydir"]  # no temporary left


def test_force_replaces_a_users_folder(tmp_path):
    user = tmp_path / "mydir"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    with atomic_directory(user, "fem", overwrite=True) as tmp:
        (tmp / "result.txt").write_text("new")
    assert sorted(p.name for p in user.iterdir()) == [RESULT_MANIFEST, "result.txt"]


def test_our_result_is_replaced_whole_and_an_empty_folder_is_taken(tmp_path):
    out = tmp_path / "run"
    out.mkdir()  # an empty folder has nothing to lose
    _write(out, "fem", "one")
    assert (out / "result.txt").read_text() == "one"
    with atomic_directory(out, "fem") as tmp:
        (tmp / "result.txt").write_text("two")
    # replaced whole: the old sub/more.txt is gone, nothing stale survives
    assert sorted(p.name for p in out.iterdir()) == [RESULT_MANIFEST, "result.txt"]
    assert (out / "result.txt").read_text() == "two"
    assert verify_manifest(out) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_file_the_user_added_to_our_result_is_not_lost(tmp_path):
    out = tmp_path / "run"
    _write(out, "fem")
    (out / "sub" / "my-plot.py").write_text("import matplotlib")
    with pytest.raises(InputError, match=r"my-plot.py in .* was not written by geocontact fem"):
        _write(out, "fem")
    assert (out / "sub" / "my-plot.py").exists()


def test_another_commands_result_is_refused(tmp_path):
    out = tmp_path / "run"
    _write(out, "sweep")
    with pytest.raises(InputError, match="holds a geocontact 'sweep' result, not a 'fem' one"):
        _write(out, "fem")


def test_a_file_at_the_out_path_is_refused(tmp_path):
    path = tmp_path / "run"
    path.write_text("a file of the user's")
    with pytest.raises(InputError, match="exists and is not a folder"):
        _write(path, "fem")
    with pytest.raises(InputError, match="exists and is not a folder"):  # --force too
        check_replaceable(path, "fem", overwrite=True)
    assert path.read_text() == "a file of the user's"


def test_manifest_lists_every_file_and_sees_changes(tmp_path):
    out = tmp_path / "run"
    _write(out, "fem", "abc")
    manifest = read_manifest(out)
    assert manifest["command"] == "fem" and manifest["schema"] == "geocontact.result/1"
    assert set(manifest["files"]) == {"result.txt", "sub/more.txt"}
    (out / "result.txt").write_text("edited")
    (out / "sub" / "more.txt").unlink()
    problems = verify_manifest(out)
    assert any("result.txt: changed" in p for p in problems)
    assert any("more.txt: missing" in p for p in problems)


# --- interrupts ---------------------------------------------------------------------------
def test_swap_is_one_rename_on_linux(tmp_path, monkeypatch):
    """With RENAME_EXCHANGE there is no moment at which the result is missing."""
    out = tmp_path / "run"
    _write(out, "fem", "one")
    renames = []
    real = os.replace
    monkeypatch.setattr(gio.os, "replace", lambda a, b: (renames.append((a, b)), real(a, b)))
    _write(out, "fem", "two")
    if sys.platform.startswith("linux"):
        assert not any(Path(b) == out for _, b in renames)  # no two-rename fallback used
    assert (out / "result.txt").read_text() == "two"


def test_interrupt_between_two_renames_is_recovered(tmp_path, monkeypatch):
    """Where only plain renames exist, an interrupt after the old result was moved aside leaves
    it under a dot-name: the next run puts it back before doing anything else."""
    out = tmp_path / "run"
    _write(out, "fem", "one")
    monkeypatch.setattr(gio, "_exchange", lambda a, b: False)
    real = os.replace

    def replace(a, b):
        if Path(b) == out:  # the second rename: the power goes out
            raise KeyboardInterrupt
        return real(a, b)

    monkeypatch.setattr(gio.os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        _write(out, "fem", "two")
    monkeypatch.setattr(gio.os, "replace", real)
    assert not out.exists()
    (stranded,) = [p for p in tmp_path.iterdir() if ".old-" in p.name]
    # as if by a dead process: give it a dead writer's name
    dead = stranded.with_name(f".run.old-{_dead_pid()}-x")
    stranded.rename(dead)
    sweep_temporaries(out)
    assert (out / "result.txt").read_text() == "one"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_temporaries_of_dead_writers_are_swept_not_live_ones(tmp_path):
    dead, live = _dead_pid(), os.getpid()
    leftovers = [tmp_path / f".run.tmp-{dead}-abc", tmp_path / f".curve.csv.tmp-{dead}-q.csv"]
    leftovers[0].mkdir()
    (leftovers[0] / "curve.csv").write_text("half")
    leftovers[1].write_text("half")
    running = tmp_path / f".run.tmp-{live}-zzz"
    running.mkdir()
    user = tmp_path / ".run.tmp-notes"  # a user's file that only looks similar
    user.write_text("mine")
    _write(tmp_path / "run", "fem")
    with gio.atomic_path(tmp_path / "curve.csv") as tmp:
        tmp.write_text("whole")
    assert not leftovers[0].exists() and not leftovers[1].exists()
    assert running.exists() and user.exists()


def test_failed_block_leaves_the_old_result(tmp_path):
    out = tmp_path / "run"
    _write(out, "fem", "one")
    with pytest.raises(RuntimeError), atomic_directory(out, "fem") as tmp:
        (tmp / "result.txt").write_text("half")
        raise RuntimeError("solver died")
    assert (out / "result.txt").read_text() == "one"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


# --- the commands -------------------------------------------------------------------------
def test_fem_cli_refuses_a_users_folder_and_force_replaces_it(tmp_path, capsys, monkeypatch):
    import geocontact.fem.run as fem_run

    history = tmp_path / "h.toml"
    history.write_text(HISTORY)
    user = tmp_path / "mydir"
    user.mkdir()
    (user / "data.xlsx").write_text("a user's file")
    args = ["fem", "--material", "reference", "--history", str(history), "--mesh", "coarse",
            "--steps", "3", "--out", str(user)]
    real_mesh = fem_run.history_mesh

    def no_fe(*args, **kwargs):
        raise AssertionError("the FE run started before the --out folder was checked")

    monkeypatch.setattr(fem_run, "history_mesh", no_fe)  # refused before the FE run
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "is not a geocontact result" in err and "--force" in err
    monkeypatch.setattr(fem_run, "history_mesh", real_mesh)
    assert (user / "data.xlsx").exists()
    assert main(args + ["--force"]) == 0
    assert not (user / "data.xlsx").exists() and (user / "summary.json").exists()
    assert main(args) == 0  # now it is ours: replaced without --force
    assert verify_manifest(user) == []


def test_cycles_rerun_that_fails_leaves_the_old_analysis_whole(tmp_path, monkeypatch):
    import geocontact.analyses.cycles as cycles
    from geocontact.grain.material import preset

    material = preset("reference")
    out = tmp_path / "cyc"
    forces = [0.0, 60.0, 0.0, 60.0, 0.0]
    cycles.run_cycles(material, forces, out, mesh="coarse", steps_per_segment=3)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}

    def broken(*args, **kwargs):
        raise RuntimeError("analysis crashed after the FE run")

    monkeypatch.setattr(cycles, "write_cycles_csv", broken)
    with pytest.raises(RuntimeError):
        cycles.run_cycles(material, forces, out, mesh="coarse", steps_per_segment=4)
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert after == before  # no new cycles.csv beside an old summary.json
    assert verify_manifest(out) == []
    # the FE of the failed rerun is kept in its checkpoint beside the folder, for --resume
    assert cycles.checkpoint_of(out).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "cyc", "cyc.fe.checkpoint.fields", "cyc.fe.checkpoint.npz"]
    monkeypatch.undo()
    summary = cycles.run_cycles(material, forces, out, mesh="coarse", steps_per_segment=4,
                                resume=True)
    assert summary["fe_run"]["inputs"]["steps_per_segment"] == 4
    assert verify_manifest(out) == [] and (out / "fe" / "fields").is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cyc"]  # checkpoint gone on landing


def test_report_keeps_a_users_report_and_replaces_its_own_figures(tmp_path, capsys):
    history = tmp_path / "h.toml"
    history.write_text(HISTORY)
    run = tmp_path / "run"
    assert main(["fem", "--material", "reference", "--history", str(history), "--mesh",
                 "coarse", "--steps", "3", "--out", str(run)]) == 0
    assert main(["report", str(run)]) == 0
    stale = run / "figures" / "stale.png"
    stale.write_bytes(b"not ours")
    capsys.readouterr()
    assert main(["report", str(run)]) == 2  # a file in figures/ we did not write
    assert "stale.png" in capsys.readouterr().err
    stale.unlink()
    assert main(["report", str(run)]) == 0
    # the report joined the FE result's manifest: the run is still replaceable as a whole
    assert "report.html" in read_manifest(run)["files"]
    assert main(["fem", "--material", "reference", "--history", str(history), "--mesh",
                 "coarse", "--steps", "3", "--out", str(run)]) == 0
    user = tmp_path / "user"
    user.mkdir()
    (user / "report.html").write_text("<html>my own report</html>")
    run2 = user / "fe"
    assert main(["fem", "--material", "reference", "--history", str(history), "--mesh",
                 "coarse", "--steps", "3", "--out", str(run2)]) == 0
    capsys.readouterr()
    assert main(["report", str(user)]) == 2
    assert "report.html exists and was not written by geocontact" in capsys.readouterr().err
    assert (user / "report.html").read_text() == "<html>my own report</html>"


def test_sigterm_exits_143_and_keeps_the_checkpoint(tmp_path):
    history = tmp_path / "h.toml"
    history.write_text("[history]\nforces = [0, 300, 0, 300, 0]\n")
    out = tmp_path / "run"
    checkpoint = tmp_path / "run.checkpoint.npz"
    cmd = [sys.executable, "-m", "geocontact.cli", "fem", "--material", "reference",
           "--history", str(history), "--mesh", "coarse", "--steps", "6", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    while not checkpoint.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert proc.poll() is None, "the run ended before a checkpoint was written"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "terminated (SIGTERM)" in err
    assert checkpoint.exists() and not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.toml", "run.checkpoint.npz"]
    assert main(cmd[3:] + ["--resume"]) == 0
    assert (out / "summary.json").exists() and not checkpoint.exists()
    assert json.loads((out / "summary.json").read_text())["cycles"][1]["max_force_N"] == 300.0


def test_a_sigterm_during_an_atomic_write_comes_after_the_file(tmp_path):
    # a SIGTERM inside np.savez's zipfile close came out as ValueError (a traceback, exit 1):
    # the signal is held while the file is written and delivered once it is in place
    from geocontact.errors import Terminated, _on_sigterm
    from geocontact.files import atomic_path

    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        with pytest.raises(Terminated):
            with atomic_path(tmp_path / "a.npz") as tmp:
                os.kill(os.getpid(), signal.SIGTERM)
                np.savez(tmp, a=np.arange(1000.0))
        with pytest.raises(Terminated):  # a failed write is still removed, the signal still comes
            with atomic_path(tmp_path / "b.npz") as tmp:
                os.kill(os.getpid(), signal.SIGTERM)
                raise OSError("disk full")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert np.load(tmp_path / "a.npz")["a"].sum() == 499500.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npz"]
    assert signal.getsignal(signal.SIGTERM) is previous


def test_pending_fields_cleanup_touches_only_the_runs_files(tmp_path):
    from geocontact.fem.checkpoint import remove_checkpoint

    checkpoint = tmp_path / "run.checkpoint.npz"
    checkpoint.write_bytes(b"x")
    pending = tmp_path / "run.checkpoint.fields"
    pending.mkdir()
    (pending / "step_00007.vtu").write_text("ours")
    (pending / f".step_00010.vtu.tmp-{_dead_pid()}-ab12.vtu").write_text("ours, half")
    remove_checkpoint(checkpoint)
    assert not checkpoint.exists() and not pending.exists()
    pending.mkdir()
    (pending / "step_00007.vtu").write_text("ours")
    (pending / "my-notes.txt").write_text("the user's")
    remove_checkpoint(checkpoint)
    assert sorted(p.name for p in pending.iterdir()) == ["my-notes.txt"]
