"""scripts/verify_finite_strain_ccx.py's command line (no CalculiX needed): the material from a
preset or a TOML file, the largest force from --force or JG's w_max, one-line errors; and the
comparison measures it adds to verification.ccx (approach at equal force, elastic recovery)."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from geocontact.grain.material import preset
from geocontact.verification import published_fits as fits
from geocontact.verification.ccx import elastic_recovery, loading_approach_at

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "verify_finite_strain_ccx", ROOT / "scripts" / "verify_finite_strain_ccx.py")
script = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(script)
WEAK = ROOT / "docs" / "verification" / "finite_strain_ccx_weak.toml"


def test_default_is_the_e_over_sigma_200_sphere_to_100_critical_interferences():
    args = script.parse_args([])
    material = preset("von-mises-large")
    jg = fits.jackson_green_critical(material)
    assert args.material == material
    assert args.peak == pytest.approx(float(fits.jackson_green_load(material, 100.0)) * jg.force)
    assert args.name == "finite_strain_ccx" and args.penalty == 100.0
    assert args.unload_to == 0.5 and args.peer_approach is None and args.max_step_ratio is None
    assert args.work == Path("out/finite_strain_ccx/coarse-contact-24-24-w100")


def test_weak_grain_from_a_toml_file_and_a_force():
    args = script.parse_args(["--material", str(WEAK), "--force", "3000", "--mesh-rule", "yield",
                              "--steps", "6", "--max-step-ratio", "1.02", "--penalty", "1",
                              "--name", "finite_strain_ccx_weak"])
    m = args.material
    assert m.youngs_modulus / m.compressive_yield_stress == pytest.approx(1e4)
    assert m.friction_angle_deg == 0.0 and m.poissons_ratio == 0.25 and m.radius == 0.1
    assert args.peak == 3000.0 and args.max_step_ratio == 1.02 and args.penalty == 1.0
    assert args.name == "finite_strain_ccx_weak"
    assert args.work.name == "finite_strain_ccx_weak-coarse-yield-6-24-F3000-r1.02"


@pytest.mark.parametrize("argv, message", [
    (["--material", "reference-weak"], "--material: CalculiX's *PLASTIC is von Mises"),
    (["--material", "no-such.toml"], "--material: material: file not found"),
    (["--force", "-1"], "--force: must be > 0"),
    (["--penalty", "0"], "--penalty: must be > 0"),
    (["--peer-approach", "nan"], "--peer-approach: must be > 0"),
    (["--unload-to", "1"], "--unload-to: must be in [0, 1)"),
    (["--max-step-ratio", "0.9"], "--max-step-ratio: must be > 1"),
])
def test_bad_input_is_one_line_naming_the_option(argv, message, capsys):
    with pytest.raises(SystemExit):
        script.parse_args(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1] and "Traceback" not in "".join(err)


def test_approach_at_equal_force_inverts_the_loading_branch():
    # loading F = d^1.5 with a dip (a node engaging under displacement control), then unloading
    approach = np.array([0.0, 1.0, 2.0, 2.5, 3.0, 3.5, 3.0, 2.8])
    force = np.array([0.0, 1.0, 2.0 ** 1.5, 2.5, 3.0 ** 1.5, 3.5 ** 1.5, 2.0, 0.0])
    run = {"approach": approach, "force": force}
    got = loading_approach_at(run, [0.0, 1.0, 2.0, 3.5, 3.0 ** 1.5, 7.0])
    # 2.0 lies on 1 -> 2; 3.5 is past the dip (2.5 at d = 2.5 after 2^1.5 at d = 2): the first
    # crossing is on 2.5 -> 3, and 2.6 (reached at d = 2 already) is not looked up in the dip
    assert got[:2] == pytest.approx([0.0, 1.0])
    assert got[2] == pytest.approx(1.0 + (2.0 - 1.0) / (2.0 ** 1.5 - 1.0))
    assert got[3] == pytest.approx(2.5 + (3.5 - 2.5) / (3.0 ** 1.5 - 2.5) * 0.5)
    assert loading_approach_at(run, [2.6])[0] < 2.0
    assert got[4] == pytest.approx(3.0) and np.isnan(got[5])
    assert elastic_recovery({"max_approach_m": 3.5, "residual_approach_m": 2.75}) == 0.75


def _run(stiffness, d_max, recovery):
    """A load-unload record: F = k d on loading to d_max, then back to F = 0 over recovery."""
    up = np.linspace(0.0, d_max, 41)
    down = np.linspace(d_max, d_max - recovery, 11)[1:]
    force = np.concatenate([stiffness * up, stiffness * d_max * np.linspace(1, 0, 11)[1:]])
    return {"approach": np.concatenate([up, down]), "force": force,
            "contact_radius": 0.1 * np.sqrt(np.concatenate([up, down])),
            "max_approach_m": d_max, "residual_approach_m": d_max - recovery,
            "max_force_N": stiffness * d_max}


def test_failure_report_compares_what_converged():
    args = script.parse_args(["--material", str(WEAK), "--force", "3000"])
    # ours: finite strain 10 % stiffer on loading; CalculiX: small ran through, NLGEOM stopped
    # at 40 % of the peak force, 20 % stiffer than CalculiX small strain
    finite, small = _run(3000.0 / 0.9, 0.9, 0.02), _run(3000.0, 1.0, 0.025)
    peers = {"ccx_small": _run(3000.0, 1.0, 0.025),
             "ccx_nlgeom": script._failed_record("ccx: run stopped at total time 0.4 of 2", {
                 "approach_m": [0.0, 0.2, 0.4], "force_N": [0.0, 720.0, 1440.0]})}
    report = script.failure_report(args, args.material,
                                   {"finite": finite, "small_to_peak": small, "small": small},
                                   peers)
    fs = report["finite_over_small"]
    assert fs["approach_at_force"]["ours"] == pytest.approx([-0.1] * 5)
    calculix = fs["approach_at_force"]["calculix"]
    assert calculix[:2] == pytest.approx([1 / 1.2 - 1] * 2) and np.isnan(calculix[2:]).all()
    assert report["ours_over_calculix_same_kinematics"]["small"] == pytest.approx([0.0] * 5)
    assert fs["ours_elastic_recovery"] == pytest.approx(0.02 / 0.025 - 1)
    assert report["calculix"]["ccx_nlgeom"]["largest_loading_approach_m"] == 0.4
    table = script.failure_table(report)
    assert "ccx: run stopped at total time 0.4 of 2" in table and "| n/a |" in table
    assert "-16.67 %" in table and "-10.00 %" in table


def test_a_ccx_run_that_stops_early_keeps_the_increments_that_converged(tmp_path, monkeypatch):
    """run_ccx on a stand-in executable that converges two increments and then reports
    CalculiX's error: ConvergenceError, with those two increments in ``partial``."""
    from geocontact.errors import ConvergenceError
    from geocontact.fem.run import history_mesh
    from geocontact.verification import ccx

    block = ("\n total force (fx,fy,fz) for set TOP and time  {t:.7E}\n\n"
             "       -2.366413E-04 {f:.6E} -3.663881E-14\n")
    dat = block.format(t=0.25, f=-1e-3) + block.format(t=0.5, f=-3e-3)
    fake = tmp_path / "ccx"
    fake.write_text(f"#!/bin/sh\nprintf '%s' '{dat}' > sphere.dat\n"
                    "echo ' *ERROR: too many cutbacks'\n")
    fake.chmod(0o755)
    monkeypatch.setattr(ccx, "ccx_executable", lambda: str(fake))
    material = preset("von-mises")
    mesh = ccx.AxisymmetricMesh.from_skfem(history_mesh(material, 1000.0, "coarse"))
    with pytest.raises(ConvergenceError, match="total time 0.5 of 2") as info:
        ccx.run_ccx(material, mesh, [4e-6, 2e-6], [4, 4])
    partial = info.value.partial
    assert partial["time"].tolist() == [0.0, 0.25, 0.5]
    assert partial["approach_m"] == pytest.approx([0.0, 1e-6, 2e-6])
    assert partial["force_N"] == pytest.approx([0.0, 0.18, 0.54])
