"""Physical claims of the hysteretic law (docs/model.md §6, docs/law.md), on random histories."""

import math

import numpy as np
import pytest
from conftest import YIELD_APPROACH, make_params
from hypothesis import given, settings
from hypothesis import strategies as st

from geocontact.analyses.force_driven import drive_by_force
from geocontact.errors import InputError
from geocontact.law import Contact, ContactArrays, CyclicLaw, LawParams, force_history
from geocontact.law.params import LoadingSegments

DY = YIELD_APPROACH

# Random approach histories in units of delta_y: from apart, through elastic, elastic-plastic
# and fully plastic depths, with reversals anywhere; the last point is apart again.
depths = st.floats(min_value=-3.0, max_value=150.0, allow_nan=False)
histories = st.lists(depths, min_size=1, max_size=25).map(
    lambda xs: [0.0, *[x * DY for x in xs], -DY]
)
PARAMS = make_params()
CYCLIC = make_params(cyclic=CyclicLaw(enabled=True, residual_ratio_coefficient=0.3,
                                      residual_ratio_power=1.2, tolerance=0.01))
# the optional forms of weak-sphere calibrations: a third loading regime from 60 dy (inside the
# histories' range) and a stretched residual form (log power b != 1, transition depth x0)
DEEP = make_params(deep_plastic_approach_ratio=60.0, deep_plastic_exponent=0.95,
                   residual_log_power=1.7, residual_transition=3.0, residual_power=0.1,
                   cyclic=CyclicLaw(enabled=True, residual_ratio_coefficient=2.3,
                                    residual_ratio_power=4.0, tolerance=0.01))

# the segments form of the virgin curve (loading.segments): five power laws, the last three
# inside the histories' range, exponents falling and rising again
SEGMENTED = make_params(loading_segments=LoadingSegments((1.0, 3.0, 12.0, 40.0, 90.0),
                                                         (1.35, 1.22, 1.05, 1.15, 0.9)),
                        cyclic=CyclicLaw(enabled=True, residual_ratio_coefficient=0.3,
                                         residual_ratio_power=1.2, tolerance=0.01))


def refine(path, per_step=7):
    """Insert points between the turning points: the law is path dependent, so the dense path is
    the same path."""
    out = [path[0]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        out += list(np.linspace(a, b, per_step + 1)[1:])
    return out


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(min_value=-1.0, max_value=1.0), min_size=1, max_size=40))
def test_below_yield_is_exactly_hertz(xs):
    contact = Contact(PARAMS)
    kh = PARAMS.hertz_coefficient
    for x in xs:
        d = x * DY
        f, k = contact.update(d)
        expected = kh * max(d, 0.0) ** 1.5
        assert f == pytest.approx(expected, rel=1e-12, abs=0.0)
        assert k == pytest.approx(1.5 * kh * math.sqrt(max(d, 0.0)), rel=1e-12, abs=0.0)
    assert contact.dissipated_energy == pytest.approx(0.0, abs=1e-15 * PARAMS.yield_force * DY)


@settings(max_examples=200, deadline=None)
@given(histories)
def test_never_tensile_and_zero_when_apart(path):
    contact = Contact(CYCLIC)
    for d in refine(path):
        f, k = contact.update(d)
        assert f >= 0.0 and k >= 0.0
        if d <= 0.0:
            assert f == 0.0
        if d - contact.state.ratchet_shift <= contact.state.residual_approach:
            assert f == 0.0


@settings(max_examples=150, deadline=None)
@given(histories, st.floats(min_value=-1.0, max_value=1.0))
def test_force_continuous_in_approach(path, direction):
    """From any state, the force after a step h goes to the current force as h -> 0."""
    contact = Contact(CYCLIC)
    for d in path:
        contact.update(d)
    f0 = contact.state.force
    scale = max(contact.state.max_force, PARAMS.yield_force)
    jumps = []
    for h in (1e-6, 1e-9, 1e-12):
        probe = Contact(CYCLIC)
        probe.state = type(contact.state)(**vars(contact.state))
        f, _ = probe.update(contact.state.approach + math.copysign(h * DY, direction))
        jumps.append(abs(f - f0) / scale)
    assert jumps[-1] < 1e-6
    assert jumps[0] >= jumps[-1] - 1e-12


@settings(max_examples=200, deadline=None)
@given(histories, st.sampled_from(["plain", "cyclic", "deep", "segmented"]))
def test_no_energy_created_on_any_path(path, which):
    """Dissipation never decreases step by step, and a path from apart to apart does
    non-negative work: the law's exact work against an independent trapezoid integration."""
    params = {"plain": PARAMS, "cyclic": CYCLIC, "deep": DEEP, "segmented": SEGMENTED}[which]
    contact = Contact(params)
    dense = refine(path, per_step=200)
    forces = []
    dissipated = 0.0
    scale = params.yield_force * DY
    for d in dense:
        f, _ = contact.update(d)
        forces.append(f)
        now = contact.dissipated_energy
        assert now >= dissipated - 1e-9 * scale - 1e-12 * abs(contact.state.work)
        dissipated = now
    assert contact.state.force == 0.0
    loop = contact.state.work
    assert loop >= -1e-9 * scale
    trapezoid = float(np.sum(0.5 * (np.array(forces[1:]) + forces[:-1]) * np.diff(dense)))
    assert trapezoid == pytest.approx(loop, rel=2e-3, abs=1e-3 * scale)


@settings(max_examples=100, deadline=None)
@given(st.floats(min_value=2.0, max_value=150.0),
       st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=2, max_size=12))
def test_partial_loops_inside_the_envelope_dissipate(depth, turning_points):
    """Unload-reload loops inside the envelope, at random depths: every closed loop does
    non-negative work, the residual approach never moves, the envelope never grows."""
    contact = Contact(PARAMS)
    dmax = depth * DY
    contact.update(dmax)
    dres = contact.state.residual_approach
    for fraction in turning_points:
        d = min(dres + fraction * (dmax - dres), dmax)
        before = contact.state.work
        start = contact.state.approach
        for x in refine([start, d, start], per_step=20)[1:]:
            contact.update(x)
        assert contact.state.work - before >= -1e-12 * max(abs(before), PARAMS.yield_force * DY)
        assert contact.state.residual_approach == dres
        assert contact.state.max_approach == dmax


@pytest.mark.parametrize("depth", [0.5, 1.0, 1.5, 4.0, 20.0, 60.0, 300.0])
def test_full_cycle_residual_approach_and_plastic_work(params, depth):
    contact = Contact(params)
    dmax = depth * DY
    for d in np.linspace(0.0, dmax, 40):
        contact.update(d)
    fmax = contact.state.force
    assert fmax == pytest.approx(float(params.virgin_force(dmax)), rel=1e-12)
    dres = float(params.residual_ratio(depth)) * dmax
    if depth <= 1.0:
        assert dres == 0.0
    else:
        assert dres > 0.0
    # unloading reaches zero exactly at the residual approach
    f, _ = contact.update(dres + 1e-9 * dmax)
    assert 0.0 < f < 1e-4 * fmax
    f, _ = contact.update(dres)
    assert f == 0.0
    contact.update(-DY)
    wp = float(params.envelope_plastic_work(dmax))
    assert contact.dissipated_energy == pytest.approx(wp, rel=1e-10, abs=1e-14)
    # reloading to dmax gives Fmax and continues on the virgin curve
    for d in np.linspace(dres, dmax, 30):
        f, _ = contact.update(d)
    assert f == pytest.approx(fmax, rel=1e-12)
    f, _ = contact.update(1.1 * dmax)
    assert f == pytest.approx(float(params.virgin_force(1.1 * dmax)), rel=1e-12)


def test_reloading_stiffer_than_unloading_and_loop_area(params):
    dmax = 30 * DY
    contact = Contact(params)
    contact.update(dmax)
    dres = contact.state.residual_approach
    grid = np.linspace(dres, dmax, 101)
    down = [contact.update(d)[0] for d in grid[::-1]][::-1]
    up = [contact.update(d)[0] for d in grid]
    assert all(u >= d_ - 1e-9 for u, d_ in zip(up, down, strict=True))
    assert up[50] > down[50]


def test_partial_unload_reload_keeps_residual_approach_and_dissipates(params):
    contact = Contact(params)
    dmax = 40 * DY
    contact.update(dmax)
    dres = contact.state.residual_approach
    w0 = contact.dissipated_energy
    mid = dres + 0.5 * (dmax - dres)
    for _ in range(5):
        for d in np.linspace(dmax, mid, 20):
            contact.update(d)
        for d in np.linspace(mid, dmax, 20):
            contact.update(d)
    assert contact.state.residual_approach == dres
    # a reload from the main unloading curve retraces it (docs/law.md): elastic, to rounding
    assert contact.dissipated_energy == pytest.approx(w0, rel=1e-12)
    f, _ = contact.update(dres)
    assert f == 0.0


def test_tangent_matches_finite_difference(params):
    contact = Contact(params)
    for d in (30 * DY, 18 * DY, 25 * DY, 12 * DY):
        contact.update(d)
    for direction in (+1.0, -1.0):
        probe = Contact(params)
        probe.state = type(contact.state)(**vars(contact.state))
        d0 = contact.state.approach
        h = 1e-7 * d0
        f0 = contact.state.force
        f1, _ = probe.update(d0 + direction * h)
        _, k1 = probe.update(d0 + 2 * direction * h)
        fd = (f1 - f0) / (direction * h)
        assert k1 == pytest.approx(fd, rel=1e-4)


def test_scalar_and_vectorised_paths_agree():
    rng = np.random.default_rng(7)
    n, steps = 64, 400
    # smooth random walks with reversals, through every regime
    increments = rng.normal(0.0, 3.0, size=(steps, n)) * DY
    paths = np.cumsum(increments, axis=0)
    paths[-10:] = -DY
    for params in (PARAMS, CYCLIC, DEEP, SEGMENTED):
        arrays = ContactArrays(params, n)
        forces = np.empty((steps, n))
        stiff = np.empty((steps, n))
        for s in range(steps):
            f, k = arrays.step(paths[s])
            forces[s], stiff[s] = f, k
        for i in range(n):
            fs, ks = force_history(params, paths[:, i])
            peak = max(max(fs), 1e-300)
            np.testing.assert_allclose(forces[:, i], fs, rtol=1e-12, atol=1e-12 * peak)
            np.testing.assert_allclose(stiff[:, i], ks, rtol=1e-12, atol=1e-12 * max(ks))
        contact = Contact(params)
        for d in paths[:, -1]:
            contact.update(d)
        assert arrays.dissipated_energy[-1] == pytest.approx(contact.dissipated_energy, rel=1e-12)


def test_hertz_kernel_is_hertz(params):
    arrays = ContactArrays.hertz(params.material, 3)
    d = np.array([-1e-5, 0.0, 3e-4])
    f, k = arrays.step(d)
    kh = params.hertz_coefficient
    np.testing.assert_allclose(f, [0.0, 0.0, kh * 3e-4**1.5], rtol=1e-14)
    np.testing.assert_allclose(k, [0.0, 0.0, 1.5 * kh * 3e-4**0.5], rtol=1e-14)
    assert np.all(arrays.dissipated_energy == 0.0)


def test_kernel_rejects_bad_input(params):
    arrays = ContactArrays(params, 2)
    with pytest.raises(InputError, match="approach"):
        arrays.step(np.array([0.0, np.nan]))
    with pytest.raises(InputError, match="shape"):
        arrays.step(np.zeros(3))
    with pytest.raises(InputError, match="approach"):
        Contact(params).update(float("inf"))


def test_repeated_cycles_ratchet_and_shake_down(cyclic_params):
    # force-controlled cycles to one peak: the reload creeps in the envelope band, unload to zero
    fmax = float(cyclic_params.virgin_force(40 * DY))
    run = drive_by_force(cyclic_params, [0.0] + [fmax, 0.0] * 30, points=40)
    residuals = [c["residual_approach_m"] for c in run.cycles]
    increments = np.diff(residuals)
    nc = cyclic_params.cyclic.critical_cycle()
    assert 2 < nc < 30
    assert np.all(increments[: nc - 2] > 0.0) and np.all(np.diff(increments[: nc - 2]) < 0.0)
    assert np.all(increments[nc - 2:] == 0.0)  # elastic shakedown from the critical cycle on


@pytest.mark.parametrize(
    "change, field",
    [
        ({"residual_limit": 1.0}, None),
        ({"elastic_plastic_exponent": 2.4, "residual_limit": 0.0}, "creates energy"),
    ],
)
def test_parameter_sets_that_would_create_energy_are_rejected(change, field):
    if field is None:
        with pytest.raises(InputError):
            LawParams.from_dict({**make_params().to_dict(),
                                 "residual_approach": {"limit": 1.0, "power": 0.3}})
        return
    with pytest.raises(InputError, match=field):
        make_params(**change)


def test_third_loading_regime_is_continuous_and_its_work_exact():
    """F continuous at delta_q with slope n3 beyond; the closed-form virgin work equals a
    numerical integral of the force across all four regimes."""
    from scipy.integrate import quad

    dq = DEEP.deep_plastic_approach
    assert dq == pytest.approx(60.0 * DY)
    below, above = DEEP.virgin_force([dq * (1 - 1e-12), dq * (1 + 1e-12)])
    assert above == pytest.approx(below, rel=1e-9)
    assert DEEP.virgin_force(2 * dq) / DEEP.virgin_force(dq) == pytest.approx(2**0.95, rel=1e-12)
    d = 5.0 * dq
    breaks = [DY, DEEP.fully_plastic_approach, dq]
    numeric = quad(lambda t: float(DEEP.virgin_force(t)), 0.0, d, points=breaks, limit=200)[0]
    assert float(DEEP.virgin_work(d)) == pytest.approx(numeric, rel=1e-9)
    # without a third regime the file reads and writes as before
    assert "deep_plastic_approach_ratio" not in PARAMS.to_dict()["loading"]
    again = LawParams.from_dict(DEEP.to_dict())
    assert again.deep_plastic_approach == pytest.approx(dq, rel=1e-15)
    assert again.residual_log_power == 1.7


def test_loading_segments_are_continuous_and_their_work_exact():
    """The segments form: F continuous at every start with the segment's slope beyond it, the
    closed-form virgin work equal to a numerical integral of the force, the inverse exact; the
    regimes written as segments are the same curve; the file round-trips."""
    from scipy.integrate import quad

    depth, exponent = SEGMENTED.loading_segments.depth, SEGMENTED.loading_segments.exponent
    starts = [x * DY for x in depth]
    for k, d in enumerate(starts):
        below, above = SEGMENTED.virgin_force([d * (1 - 1e-12), d * (1 + 1e-12)])
        assert above == pytest.approx(below, rel=1e-9)
        slope = math.log(SEGMENTED.virgin_force(d * 1.01) / SEGMENTED.virgin_force(d)) / math.log(
            1.01)
        assert slope == pytest.approx(exponent[k], rel=1e-9)
        assert SEGMENTED.virgin_exponent(d * 1.01) == exponent[k]
    for d in (0.5 * DY, 2.0 * DY, 30.0 * DY, 500.0 * DY):
        numeric = quad(lambda t: float(SEGMENTED.virgin_force(t)), 0.0, d,
                       points=[s for s in starts if s < d], limit=200, epsabs=0.0,
                       epsrel=1e-12)[0]
        assert float(SEGMENTED.virgin_work(d)) == pytest.approx(numeric, rel=1e-9)
        assert SEGMENTED.virgin_approach(float(SEGMENTED.virgin_force(d))) == pytest.approx(
            d, rel=1e-12)
    # the regime fields mirror the first segments (readers of n1, r_p, n2, r_q, n3)
    assert (SEGMENTED.elastic_plastic_exponent, SEGMENTED.fully_plastic_approach_ratio,
            SEGMENTED.fully_plastic_exponent, SEGMENTED.deep_plastic_approach_ratio) == (
                1.35, 3.0, 1.22, 12.0)
    # three regimes written as segments: the same curve and work
    as_segments = make_params(loading_segments=LoadingSegments(
        (1.0, DEEP.fully_plastic_approach_ratio, DEEP.deep_plastic_approach_ratio),
        (DEEP.elastic_plastic_exponent, DEEP.fully_plastic_exponent,
         DEEP.deep_plastic_exponent)), deep_plastic_approach_ratio=60.0,
        residual_log_power=1.7, residual_transition=3.0, residual_power=0.1)
    d = np.geomspace(0.1, 1e4, 200) * DY
    np.testing.assert_allclose(as_segments.virgin_force(d), DEEP.virgin_force(d), rtol=1e-14)
    np.testing.assert_allclose(as_segments.virgin_work(d), DEEP.virgin_work(d), rtol=1e-13)
    document = SEGMENTED.to_dict()
    assert set(document["loading"]) == {"segments"}
    again = LawParams.from_dict(document)
    assert again.loading_segments == SEGMENTED.loading_segments
    np.testing.assert_array_equal(again.virgin_force(d), SEGMENTED.virgin_force(d))


@pytest.mark.parametrize("segments, message", [
    (((1.0,), (1.3,)), r"^loading\.segments\.depth: must have 2 to 16 entries, got 1$"),
    (((1.0, 3.0), (1.3, 1.2, 1.1)), r"^loading\.segments\.exponent: must have as many "
                                    r"entries as loading\.segments\.depth \(2\), got 3$"),
    (((2.0, 3.0), (1.3, 1.2)), r"^loading\.segments\.depth\[0\]: the first segment starts at "
                               r"yield, must be 1, got 2$"),
    (((1.0, 3.0, 3.0), (1.3, 1.2, 1.1)), r"^loading\.segments\.depth\[2\]: must be above "),
    (((1.0, 3.0), (1.3, 3.5)), r"^loading\.segments\.exponent\[1\]: "),
])
def test_bad_loading_segments_are_one_line_errors(segments, message):
    """Segments built in code meet the file's rules, with the readers' messages."""
    with pytest.raises(InputError, match=message):
        make_params(loading_segments=LoadingSegments(*segments))


def test_stretched_residual_form_reduces_to_the_original_with_b_1():
    from geocontact.law.params import saturating_ratio

    x = np.geomspace(1.0, 1e6, 50)
    assert saturating_ratio(x, 0.9, 0.35, 1.0, 1.0) == pytest.approx(0.9 * (1 - x**-0.35),
                                                                     abs=1e-15)
    stretched = saturating_ratio(x, 0.9, 0.1, 3.0, 1.7)
    assert stretched[0] == 0.0 and np.all(np.diff(stretched) > 0) and stretched[-1] < 0.9
    assert stretched == pytest.approx(0.9 * (1 - np.exp(-0.1 * np.log1p((x - 1) / 3) ** 1.7)),
                                      rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("edit, field", [
    ({"deep_plastic_approach_ratio": 10.0, "deep_plastic_exponent": 1.0},
     "loading.deep_plastic_approach_ratio"),
    ({"deep_plastic_approach_ratio": 100.0, "deep_plastic_exponent": 0.0},
     "loading.deep_plastic_exponent"),
])
def test_third_regime_out_of_range_is_a_one_line_error(edit, field):
    doc = PARAMS.to_dict()
    doc["loading"].update(edit)
    with pytest.raises(InputError, match=field):
        LawParams.from_dict(doc)


# --- the compiled core (the C++ header through geocontact.law._core) -----------------------
def _random_walks(params, n, steps, seed):
    rng = np.random.default_rng(seed)
    paths = np.cumsum(rng.normal(0.0, 3.0, size=(steps, n)), axis=0) * params.yield_approach
    paths[-5:] = -params.yield_approach
    return paths


def _bits(values: np.ndarray) -> np.ndarray:
    """The bytes of an array (state views are strided: one record per contact)."""
    return np.ascontiguousarray(values).view(np.uint8)


def test_results_are_bitwise_the_same_for_any_thread_count():
    """Contacts are independent: splitting them over threads changes no bit of any output or
    state field (compared as integers, so -0.0 != 0.0 would count)."""
    n, steps = 20_000, 60
    paths = _random_walks(DEEP, n, steps, seed=3)
    runs, seen = {}, set()
    for threads in (1, 2, 3, 4):
        arrays = ContactArrays(DEEP, n, threads=threads)
        outputs = []
        for row in paths:
            f, k = arrays.step(row)
            outputs += [f.copy(), k.copy()]
            seen.update(np.unique(arrays.branch).tolist())
        runs[threads] = [*outputs, *arrays.state.as_dict().values()]
    for threads in (2, 3, 4):
        for ours, one in zip(runs[threads], runs[1], strict=True):
            assert ours.dtype == one.dtype
            assert np.array_equal(_bits(ours), _bits(one))
    # the population really went through every branch
    assert seen == {0, 1, 2, 3, 4}


def test_state_is_named_arrays_matching_the_reference_state():
    from geocontact.law.kernel import STATE_FIELDS

    n, steps = 12, 80
    paths = _random_walks(CYCLIC, n, steps, seed=5)
    arrays = ContactArrays(CYCLIC, n)
    for row in paths[:-5]:
        arrays.step(row)
    state = arrays.state.as_dict()
    assert tuple(state) == STATE_FIELDS
    assert state["branch"].dtype == np.int8 and state["work"].dtype == np.float64
    for i in range(n):
        contact = Contact(CYCLIC)
        for d in paths[:-5, i]:
            contact.update(d)
        for name in STATE_FIELDS:
            expected = getattr(contact.state, name)
            assert state[name][i] == pytest.approx(expected, rel=1e-11, abs=1e-300), name
    # the arrays are views of the core's state: a contact set by hand steps from there
    arrays.state.approach[0] = 0.0
    arrays.state.branch[0] = 0
    for name in ("force", "max_approach", "max_force", "residual_approach", "ratchet_shift",
                 "pending_ratchet", "cycles", "work"):
        arrays.state.as_dict()[name][0] = 0.0
    f, _ = arrays.step(np.full(n, 0.5 * DY))
    assert f[0] == pytest.approx(PARAMS.hertz_coefficient * (0.5 * DY) ** 1.5, rel=1e-14)
    arrays.reset()
    assert np.all(arrays.state.work == 0.0) and np.all(arrays.state.unloading_exponent == 1.5)


def test_state_of_contacts_on_the_virgin_curve_is_up_to_date_when_read():
    """The array step computes a climbing contact's envelope (residual approach, n_u, n_r, the
    cycle count) only when it leaves the virgin curve; reading ``state`` brings it up to date:
    at every step the envelope matches the reference's, and a run whose state is never read
    ends bitwise the same (reading changes nothing that follows)."""
    n, steps = 40, 70
    rng = np.random.default_rng(11)
    # mostly climbing (the virgin curve), with reversals and new excursions beyond the envelope
    paths = np.cumsum(rng.normal(0.4, 1.0, size=(steps, n)), axis=0) * DY
    for params in (CYCLIC, DEEP):
        read, unread = ContactArrays(params, n), ContactArrays(params, n)
        contacts = [Contact(params) for _ in range(n)]
        on_virgin = 0
        for row in paths:
            read.step(row)
            unread.step(row)
            state = read.state
            for i, contact in enumerate(contacts):
                contact.update(row[i])
                if state.branch[i] != 1 or state.max_approach[i] <= DY:
                    continue
                on_virgin += 1
                for name in ("residual_approach", "unloading_exponent", "reloading_exponent",
                             "cycles"):
                    expected = getattr(contact.state, name)
                    assert state.as_dict()[name][i] == pytest.approx(expected, rel=1e-11), name
        assert on_virgin > steps  # the check really saw contacts climbing past yield
        ours, theirs = read.state.as_dict(), unread.state.as_dict()
        for name in ours:
            assert np.array_equal(_bits(ours[name]), _bits(theirs[name])), name


def test_core_derives_the_constants_of_the_python_parameters():
    from geocontact.law.kernel import core_params

    for params in (PARAMS, CYCLIC, DEEP, SEGMENTED):
        core = core_params(params)
        for name in ("hertz_coefficient", "yield_force", "fully_plastic_approach",
                     "fully_plastic_force"):
            assert getattr(core, name) == getattr(params, name), name
    assert core_params(DEEP).deep_plastic_force == pytest.approx(DEEP.deep_plastic_force,
                                                                 rel=1e-15)
    assert core_params(DEEP).segment_depths == [1.0, 20.0, 60.0]
    core = core_params(SEGMENTED)
    assert core.segment_depths == list(SEGMENTED.loading_segments.depth)
    assert core.segment_exponents == list(SEGMENTED.loading_segments.exponent)


def test_threads_argument_is_checked():
    with pytest.raises(InputError, match="threads"):
        ContactArrays(PARAMS, 4, threads=0)
    arrays = ContactArrays(PARAMS, 4)
    assert arrays.threads == 1
    arrays.threads = 2
    assert arrays.threads == 2
    with pytest.raises(InputError, match="threads"):
        arrays.threads = -1
    with pytest.raises(ValueError, match="shape"):
        arrays.step_unchecked(np.zeros(5))


def test_compiled_core_is_built_from_these_sources():
    """The extension records a hash of the C++ sources it was compiled from (CMakeLists.txt);
    a stale build (a header edited without reinstalling: `make .venv/.installed`) fails here."""
    import hashlib
    from pathlib import Path

    from geocontact.law import _core

    root = Path(__file__).resolve().parents[1]
    sources = ["src/geocontact/law/_core.cpp", "plugins/lammps/include/geocontact/law.hpp",
               "plugins/lammps/include/geocontact/arrays.hpp",
               "plugins/lammps/include/geocontact/params.hpp",
               "plugins/lammps/include/geocontact/json.hpp", "src/geocontact/data/law-schema.json"]
    if not all((root / s).exists() for s in sources):
        pytest.skip("not a source tree")
    hashes = ";".join(hashlib.sha256((root / s).read_bytes()).hexdigest() for s in sources)
    assert _core.SOURCE_HASH == hashlib.sha256(hashes.encode()).hexdigest(), (
        "geocontact.law._core was built from other sources: run make .venv/.installed")
