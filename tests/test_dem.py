"""``geocontact dem oedometer`` (examples/lammps/in.oedometer through the driver; plugin built by
`make plugin`): a small polydisperse sample generated in LAMMPS, compressed to the stress and
cycled, for the geocontact law and LAMMPS's granular Hertz-Mindlin, on 1 and 2 ranks."""

from __future__ import annotations

import csv
import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from geocontact.analyses.dem import Settings, run_dem
from geocontact.cli import main
from geocontact.cli.dem import TESTS_TAKING
from geocontact.files import read_csv_column, verify_manifest

LAW = Path("examples/params-reference.json")
# the smallest sample that jams: 300 grains, a fast quasi-static rate, one cycle
SMALL = {"grains": 300, "inertia": 1e-2, "targets": (1.5, 0.5)}


@pytest.fixture(scope="module")
def both(tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("dem") / "oedometer"
    return out, run_dem("oedometer", LAW, Settings(**SMALL),
                        contacts=("geocontact", "elastic", "granular"), ranks=1, out=out)


def test_stress_reached_and_outputs_parsed(both):
    out, doc = both
    assert verify_manifest(out) == []
    assert json.loads((out / "summary.json").read_text())["schema"] == "geocontact.dem/1"
    for contact, run in doc["runs"].items():
        assert run["grains"] == SMALL["grains"]
        # the stress before the cycles and each reversal: reached, within a few % past it
        assert 5e3 <= run["reference_stress_Pa"] < 1.05 * 5e3
        (cycle,) = run["cycles"]
        assert 7.5e3 <= cycle["peak_stress_Pa"] < 1.1 * 7.5e3
        assert 0.9 * 2.5e3 < cycle["valley_stress_Pa"] <= 2.5e3
        # a jammed sample: packing fraction of a loose polydisperse packing, contacts
        assert 0.55 < run["packing_fraction"] < 0.72
        assert run["contacts_per_grain_at_stress"] > 1.5
        # the cycle dissipates: positive work of the top wall around the loop
        assert cycle["wall_work_J"] > 0
        assert run["timestep_s"] < 0.25 * run["hertz_time_s"]
        strain = read_csv_column(out / contact / "series.csv", "strain")
        stress = read_csv_column(out / contact / "series.csv", "stress_Pa")
        assert len(strain) == len(stress) > 50
        assert read_csv_column(out / contact / "cycles.csv", "cycle").tolist() == [1]


def test_the_time_step_is_checked_against_the_contacts_critical_step(both):
    """examples/lammps/timestep.lmp: the smallest critical time step of geocontact's contacts
    at the leg ends: the step the example chose (dtfrac 0.2 of the Hertz bound at 10 times the
    peak force, 0.14 of its critical step) is a larger fraction of it (the stiffest contact,
    plastic and after the fast first leg, is stiffer than the bound), still below dtsafe = 0.3,
    without a warning; the granular run has no geocontact contacts to check."""
    _, doc = both
    geo, granular = doc["runs"]["geocontact"], doc["runs"]["granular"]
    hertz_bound = math.sqrt(2) * geo["hertz_time_s"]  # 2 sqrt(m_min / (2 k_bound))
    assert 0.15 < geo["timestep_s"] / geo["critical_timestep_min_s"] < 0.3
    assert geo["critical_timestep_min_s"] < hertz_bound
    assert geo["timestep_warning_step"] is None
    assert granular["critical_timestep_min_s"] is None


def test_geocontact_dents_granular_does_not(both):
    out, doc = both
    g, h = doc["runs"]["geocontact"], doc["runs"]["granular"]
    # 5 kPa on mm grains: contact forces far above the yield force (2.8e-4 N at r = 1 mm), so
    # most contacts that carried load keep a residual approach, and the law dissipates
    ra = g["residual_approach"]
    assert ra["plastic"] > 0.5 * ra["in_contact"] > 0
    res = read_csv_column(out / "geocontact" / "residual_approach.csv", "residual_approach_m")
    top = read_csv_column(out / "geocontact" / "residual_approach.csv", "max_approach_m")
    assert np.all(res >= 0) and np.all(res <= top)
    assert g["cycles"][0]["law_dissipated_J"] > 0
    assert h["cycles"][0]["law_dissipated_J"] == 0
    assert "residual_approach" not in h
    assert not (out / "granular" / "residual_approach.csv").exists()


def test_the_elastic_baseline_runs_the_same_pair_style_without_a_dent(both):
    """contact elastic: the grain's elastic law file (law.elastic, written beside the runs)
    through pair geocontact and the geocontact walls: no contact dents, the law dissipates
    nothing, and the same restitution as the others (that of damping 0.5: 0.273)."""
    out, doc = both
    e = doc["runs"]["elastic"]
    elastic_file = json.loads((out / "law-elastic.json").read_text())
    assert elastic_file["yield"]["approach_m"] == 0.5 * elastic_file["material"]["radius"]
    assert e["residual_approach"]["plastic"] == 0 < e["residual_approach"]["in_contact"]
    # the law's tally is round-off (work - stored energy of exact Hertz): 1e-12 of the wall work
    assert abs(e["cycles"][0]["law_dissipated_J"]) < 1e-12 * e["cycles"][0]["wall_work_J"]
    assert e["cycles"][0]["wall_work_J"] > 0  # sliding and damping still dissipate
    assert doc["restitution"] == pytest.approx(0.2732, abs=1e-4)
    assert "restitution 0.273" in (out / "elastic" / "run.txt").read_text()


def test_coordination_counts_contacts_that_carry_force(both):
    """geocontact's contacts per grain are the pairs whose force is positive (compute pair
    geocontact [3]): the plastic law's force-free overlaps below delta_res are not counted."""
    out, doc = both
    for contact in ("geocontact", "elastic", "granular"):
        assert 1.5 < doc["runs"][contact]["contacts_per_grain_at_stress"] < 8.0


def test_report_section(both, tmp_path):
    out, _ = both
    from geocontact.report import build_report

    html = build_report(out)
    text = html.read_text()
    assert "DEM oedometer" in text
    assert "Void ratio against log vertical stress" in text and "M unload (MPa)" in text
    for name in ("dem_loops", "dem_cycles", "dem_residual_approach", "dem_void_ratio"):
        assert (out / "figures" / f"{name}.png").stat().st_size > 1000


def ledger_closes(run, share=0.01, plastic=True):
    """The energy ledger of a run of the plugin's pair and walls: the walls' work equals the
    change of kinetic and stored energy plus what was dissipated, within `share` of the work,
    over the cycles and over each cycle; the dashpots at work, and the law too if `plastic`
    (the elastic law dissipates nothing)."""
    for energy in (run["energy"], *(c["energy"] for c in run["cycles"])):
        assert energy["boundary_work_J"] > 0
        assert abs(energy["closure_residual_J"]) < share * energy["boundary_work_J"]
    d = run["energy"]["dissipated_J"]
    assert d["normal_damping"] > 0 and d["tangential_damping"] > 0
    if plastic:
        assert d["law"] > 0
    else:
        assert abs(d["law"]) < 1e-12 * run["energy"]["boundary_work_J"]
    assert run["energy"]["tangential_total_J"] > 0


def test_energy_ledger_closes_within_one_percent_of_the_wall_work(both):
    """The plastic law and its like-for-like elastic baseline (the same pair, walls and ledger)."""
    _, doc = both
    ledger_closes(doc["runs"]["geocontact"])
    ledger_closes(doc["runs"]["elastic"], plastic=False)
    assert "energy" not in doc["runs"]["granular"]  # LAMMPS's pair: no ledger


def test_one_and_two_ranks_agree_statistically(tmp_path):
    """The geocontact law on 1 and 2 ranks, walls fix wall/geocontact. Same seed,
    same positions, but LAMMPS's per-rank random streams give the grains other radii on 2 ranks
    (and force sums run in another order, which a granular packing amplifies), so the two are
    different realisations of the sample: compared statistically, at the scatter of a
    300-grain sample."""
    settings = {**SMALL, "walls": "geocontact"}
    one, two = (run_dem("oedometer", LAW, Settings(**settings), contacts=("geocontact",),
                        ranks=ranks, out=tmp_path / f"r{ranks}")["runs"]["geocontact"]
                for ranks in (1, 2))
    assert (one["ranks"], two["ranks"]) == (1, 2)
    assert abs(two["packing_fraction"] - one["packing_fraction"]) < 0.03
    for run in (one, two):
        assert 5e3 <= run["reference_stress_Pa"] < 1.05 * 5e3
        assert run["cycles"][0]["wall_work_J"] > 0 and run["cycles"][0]["law_dissipated_J"] > 0
    z1, z2 = one["contacts_per_grain_at_stress"], two["contacts_per_grain_at_stress"]
    assert abs(z1 - z2) < 0.5
    for run in (one, two):  # most loaded contacts dented, on either rank count
        ra = run["residual_approach"]
        assert ra["plastic"] > 0.5 * ra["in_contact"] > 0
        ledger_closes(run)


def test_memory_flag_reaches_the_pair_style(tmp_path):
    """--memory place: the run's pair style and its geocontact walls forget dents past the
    contact diameter (docs/dem.md "Memory with a place"); the choice is in the run's log and
    its inputs, and the law's tally never falls (the energy-safe reset creates no energy)."""
    out = tmp_path / "oed"
    assert main(["dem", "oedometer", "--law", str(LAW), "--grains", "300", "--inertia", "1e-2",
                 "--targets", "1.5", "0.5", "--contact", "geocontact", "--memory", "place",
                 "--out", str(out)]) == 0
    log = (out / "geocontact.log").read_text()
    assert "pair_style geocontact memory place" in log
    # the floor and the top wall
    assert "memory place zplane 0 NULL" in log and "memory place zplane NULL" in log
    law = read_csv_column(out / "geocontact" / "series.csv", "law_dissipated_J")
    assert np.all(np.diff(law) >= 0)
    inputs = json.loads((out / "summary.json").read_text())["provenance"]["inputs"]
    assert inputs["extra"]["memory"] == "place"


def test_bad_arguments_one_line(tmp_path, capsys):
    assert main(["dem", "oedometer", "--law", str(LAW), "--grains", "10",
                 "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--grains: must be in [50, 200000]" in err
    assert main(["dem", "oedometer", "--law", str(LAW), "--targets", "0.5", "1.5",
                 "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--targets:" in err
    assert main(["dem", "seismic", "KOBE/NIS000", "--law", str(LAW), "--preset", "high-stress",
                 "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--preset: only for the oedometer test" in err
    assert main(["dem", "oedometer", "--law", str(tmp_path / "none.json"),
                 "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("error: --law: file not found")
    assert not (tmp_path / "x").exists()


def test_sigterm_stops_lammps_and_leaves_nothing(tmp_path):
    out = tmp_path / "run"
    process = subprocess.Popen(
        [sys.executable, "-m", "geocontact.cli", "dem", "oedometer", "--law", str(LAW),
         "--grains", "300", "--out", str(out)], stderr=subprocess.PIPE, text=True)
    line = process.stderr.readline()  # the first progress line: LAMMPS is starting
    assert "geocontact: 300 grains" in line
    time.sleep(1.0)
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=30) == 143
    assert not out.exists()
    assert [p for p in tmp_path.iterdir()] == []  # the temporary folder removed too
    ps = subprocess.run(["ps", "-o", "pid=", "--ppid", str(process.pid)], capture_output=True,
                        text=True)
    assert ps.stdout.strip() == ""


def test_void_ratio_and_compressibility_of_the_cycle(both):
    """Issue 35: the oedometer as engineers read it. e = V_voids/V_solid is 1/phi - 1 of the
    packing fraction at the stress before the cycles and follows the strain, e = (1 + e0)(1 -
    eps) - 1; the cycle loads past the largest stress the sample saw (5 to 7.5 kPa) and unloads
    to 2.5 kPa: the dented packing unloads stiffer than it loaded (M_unload > M_reload) and swells
    less than it compressed (Cs < Cc)."""
    out, doc = both
    g = doc["runs"]["geocontact"]
    e0 = g["void_ratio_at_stress"]
    assert e0 == pytest.approx(1 / g["packing_fraction"] - 1, rel=1e-12)
    series = out / "geocontact" / "series.csv"
    e, eps = read_csv_column(series, "void_ratio"), read_csv_column(series, "strain")
    assert np.allclose(e, (1 + e0) * (1 - eps) - 1, rtol=0, atol=1e-9)
    (c,) = g["cycles"]
    assert c["peak_void_ratio"] == pytest.approx((1 + e0) * (1 - c["peak_strain"]) - 1)
    assert c["valley_void_ratio"] == pytest.approx((1 + e0) * (1 - c["end_strain"]) - 1)
    assert c["peak_void_ratio"] < c["valley_void_ratio"] and c["peak_void_ratio"] < e0
    assert c["unload_modulus_Pa"] > c["reload_modulus_Pa"] > 0
    assert c["unload_modulus_initial_Pa"] > 0
    assert 0 < c["swelling_index"] < c["compression_index"]
    # the constrained modulus by its definition, from the reversal's numbers
    assert c["unload_modulus_Pa"] == pytest.approx(
        (c["peak_stress_Pa"] - c["valley_stress_Pa"]) / (c["peak_strain"] - c["end_strain"]))
    cycles_csv = out / "geocontact" / "cycles.csv"
    for name in ("peak_void_ratio", "unload_modulus_Pa", "swelling_index", "loop_area_J_m3"):
        assert read_csv_column(cycles_csv, name)[0] == pytest.approx(c[name])


def test_loop_area_is_the_walls_work_per_volume(both):
    """The loop area, the integral of sigma d eps around the cycle per unit reference volume:
    of the virial stress it is the cycle's wall work from the virial over the volume; of the top
    wall's force over the area (sampled every 20 steps) it is the walls' work measured where the
    energy enters, every step, by the energy ledger (F . v_wall dt of fix wall/geocontact): two
    measurements of one quantity, within 10 %. The virial's loop is smaller at this fast rate
    (inertia number 0.015): it misses the wall contacts and the grains' inertia (docs/dem.md)."""
    _, doc = both
    for contact in ("geocontact", "elastic"):
        run = doc["runs"][contact]
        volume = run["side_m"] ** 2 * run["reference_height_m"]
        (c,) = run["cycles"]
        assert c["loop_area_J_m3"] * volume == pytest.approx(c["wall_work_J"], rel=1e-12)
        assert 0 < c["loop_area_J_m3"] < c["loop_area_top_wall_J_m3"]
        assert c["loop_area_top_wall_J_m3"] == pytest.approx(
            c["energy"]["boundary_work_J"] / volume, rel=0.1)
    assert doc["runs"]["granular"]["cycles"][0]["loop_area_top_wall_J_m3"] is None


@pytest.fixture(scope="module")
def high_stress(tmp_path_factory) -> tuple[Path, dict]:
    """`--preset high-stress` (0.5 MPa, then 1 and 2 MPa with a loop to a quarter each), both
    laws on the small sample, through the command."""
    out = tmp_path_factory.mktemp("dem") / "high"
    assert main(["dem", "oedometer", "--law", str(LAW), "--grains", "300", "--inertia", "1e-2",
                 "--preset", "high-stress", "--contact", "both", "--out", str(out)]) == 0
    return out, json.loads((out / "summary.json").read_text())


def test_high_stress_preset_loops(high_stress):
    """At MPa the reference grain's contacts yield deeply: the dented packing unloads stiffer and
    swells less than the same sample of elastic contacts (M_unload several times, Cs a fraction),
    and on each loop stiffer than it reloads; the loop at a peak reached before (cycles 2, 4:
    recompression) compresses less than the virgin loading to it (cycles 1, 3)."""
    _, doc = high_stress
    g, e = doc["runs"]["geocontact"], doc["runs"]["elastic"]
    assert [c["peak_target_Pa"] for c in g["cycles"]] == [1e6, 1e6, 2e6, 2e6]
    for cg, ce in zip(g["cycles"], e["cycles"], strict=True):
        assert cg["unload_modulus_Pa"] > 2 * ce["unload_modulus_Pa"]
        assert cg["swelling_index"] < 0.5 * ce["swelling_index"]
        assert cg["unload_modulus_Pa"] > cg["reload_modulus_Pa"]
        assert 0 < cg["swelling_index"] < cg["compression_index"]
        assert cg["loop_area_J_m3"] > 0
    virgin, reload = g["cycles"][0::2], g["cycles"][1::2]
    for v, r in zip(virgin, reload, strict=True):
        assert r["compression_index"] < v["compression_index"]


def test_high_stress_depth_against_the_calibrated_range(high_stress):
    """The deepest contact the run reaches, compute pair geocontact [17], against the law file's
    calibrated range (max_depth 249 delta_y, 6000 N on R = 0.1 m): at 2 MPa the contacts of
    mm grains go far beyond it (the issue's estimate: ~8 N, ~10^4 Fy), and the pair's depth lies
    between the bounds from the dumped largest approaches, delta_max / delta_y(R_eff) with the
    yield approach delta_y proportional to R_eff (similarity) between the smallest and largest
    grains' pair (R_eff = r_min/2 .. r_max/2). The elastic baseline (yield at R/2) never goes
    beyond its range."""
    out, doc = high_stress
    g = doc["runs"]["geocontact"]["calibrated_range"]
    law = json.loads(LAW.read_text())
    assert g["calibrated_max_depth"] == pytest.approx(law["calibrated_range"]["max_depth"])
    assert g["beyond_range_contacts"] > 0 and g["walls_beyond_range_contacts"] > 0
    assert g["beyond_range_max_depth"] > 10 * g["calibrated_max_depth"]
    run = (out / "geocontact" / "run.txt").read_text().split("\n")
    radius = {k: float(v) for k, v in (line.split() for line in run
                                       if line.startswith("radius_m"))}
    deepest = read_csv_column(out / "geocontact" / "residual_approach.csv", "max_approach_m").max()
    per_radius = law["yield"]["approach_m"] / law["material"]["radius"]
    lowest = deepest / (per_radius * radius["radius_max_m"] / 2)
    highest = deepest / (per_radius * radius["radius_min_m"] / 2)
    assert lowest <= g["beyond_range_max_depth"] <= highest
    e = doc["runs"]["elastic"]["calibrated_range"]
    assert e["beyond_range_contacts"] == 0 == e["walls_beyond_range_contacts"]


# A valid value of each flag that only some tests take (cli.dem.TESTS_TAKING).
ONLY_SOME_TESTS = {
    "preset": ["--preset", "high-stress"], "walls": ["--walls", "elastic"],
    "targets": ["--targets", "1.5"], "strain": ["--strain", "0.01"],
    "decimate": ["--decimate", "2"], "baseline": ["--baseline", "elastic"],
    "restitution": ["--restitution", "0.5"], "memory": ["--memory", "place"],
    "amplitudes": ["--amplitudes", "1e-6", "1e-5"], "cycles": ["--cycles", "3"],
    "seeds": ["--seeds", "2"], "friction": ["--friction", "0.5"],
    "damping": ["--damping", "0.1"], "drained": ["--drained"],
    "cyclic_extension": ["--cyclic-extension", "off"],
}


@pytest.mark.parametrize("flag", sorted(TESTS_TAKING))
def test_every_test_refuses_the_flags_it_does_not_take(tmp_path, capsys, flag):
    """Each flag of TESTS_TAKING, given to each test not in its entry: exit 2, one line naming
    the flag and the tests that take it, nothing written."""
    others = [t for t in ("oedometer", "seismic", "cyclic-shear") if t not in TESTS_TAKING[flag]]
    assert others and set(ONLY_SOME_TESTS) == set(TESTS_TAKING)
    for test in others:
        record = ["KOBE/NIS000"] if test == "seismic" else []
        assert main(["dem", test, *record, "--law", str(LAW), *ONLY_SOME_TESTS[flag],
                     "--out", str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err.strip()
        option = flag.replace("_", "-")
        assert "\n" not in err and f"--{option}: only for the {TESTS_TAKING[flag][0]}" in err
        assert f"not for {test}" in err
        assert not (tmp_path / "x").exists()


def test_seeds_give_each_cycles_mean_and_spread_over_the_samples(tmp_path, capsys):
    """`--seeds 2`: two samples (seeds 11, 12) in seed-11/ and seed-12/, each a whole result
    folder of its own, and summary.json's statistics are those of the samples' own cycles;
    cycles.csv has every sample's cycle. A folder of the user's in the way is refused."""
    from geocontact.analyses.dem_seeds import MEASURES

    out = tmp_path / "seeds"
    assert main(["dem", "oedometer", "--law", str(LAW), "--grains", "300", "--inertia", "1e-2",
                 "--targets", "1.5", "0.5", "--seed", "11", "--seeds", "2",
                 "--contact", "both", "--out", str(out)]) == 0
    assert "2 samples (seeds 11-12)" in capsys.readouterr().out
    assert verify_manifest(out) == []
    doc = json.loads((out / "summary.json").read_text())
    assert doc["schema"] == "geocontact.dem-seeds/1" and doc["seeds"] == [11, 12]
    runs = [json.loads((out / f"seed-{s}" / "summary.json").read_text())["runs"]["geocontact"]
            for s in (11, 12)]
    assert runs[0]["packing_fraction"] != runs[1]["packing_fraction"]  # two samples
    (cycle,) = doc["laws"]["geocontact"]["cycles"]
    for m in ("peak_void_ratio", "unload_modulus_Pa", "loop_area_top_wall_J_m3", "wall_work_J"):
        values = [r["cycles"][0][m] for r in runs]
        assert cycle[m]["count"] == 2
        assert cycle[m]["mean"] == pytest.approx(np.mean(values), rel=1e-12)
        assert cycle[m]["std"] == pytest.approx(np.std(values, ddof=1), rel=1e-9)
        assert cycle[m]["min"] == min(values) and cycle[m]["max"] == max(values)
    assert set(cycle) == {"cycle", "history", *MEASURES}
    # like for like: the law over its elastic baseline on the same sample, seed by seed
    elastic = [json.loads((out / f"seed-{s}" / "summary.json").read_text())["runs"]["elastic"]
               for s in (11, 12)]
    (ratio,) = doc["paired"]["geocontact/elastic"]
    ratios = [g["cycles"][0]["unload_modulus_Pa"] / e["cycles"][0]["unload_modulus_Pa"]
              for g, e in zip(runs, elastic, strict=True)]
    assert ratio["unload_modulus_Pa"]["mean"] == pytest.approx(np.mean(ratios), rel=1e-12)
    assert read_csv_column(out / "cycles.csv", "seed").tolist() == [11, 12, 11, 12]
    with open(out / "cycles.csv") as f:
        assert [row["contact"] for row in csv.DictReader(f)] == ["geocontact"] * 2 + [
            "elastic"] * 2
    assert main(["report", str(out)]) == 0
    page = (out / "report.html").read_text()
    assert "DEM oedometer, 2 samples" in page and "DEM oedometer seed-12" in page
    assert verify_manifest(out) == []
    (out / "mine.txt").write_text("a user's file")
    assert main(["dem", "oedometer", "--law", str(LAW), "--grains", "300", "--seeds", "2",
                 "--out", str(out)]) == 2
    assert (out / "mine.txt").exists() and "not written by geocontact" in capsys.readouterr().err
