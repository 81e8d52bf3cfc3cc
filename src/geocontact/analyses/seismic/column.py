"""A vertical column of identical spheres on a moving base: explicit dynamics with the law.

Model (docs/seismic.md):

* N identical spheres (material and radius of the law parameters, density given) stacked on a
  base; sphere 0 is the top one. Contact k is below sphere k: between spheres k and k+1, and for
  k = N-1 between the bottom sphere and an identical grain fixed to the base, so that every
  contact is a ball-ball pair of the law (docs/model.md §2) and reports its ball-ball approach.
* Gravity g and an optional surcharge force S on the top sphere. The base moves vertically with
  the record's acceleration a_b(t) (positive up); the column is integrated in coordinates
  relative to the base, x_k (up, from the unstressed touching configuration), where the base
  motion is the inertial load -m a_b on every sphere:

      m x_k'' = P_k - P_{k-1} - m g - m a_b(t),   P_{-1} = S,   approach_k = x_{k+1} - x_k,

  with x_N = 0 (the base grain) and P_k the contact force (law + optional viscous damping).
* Static start: contact k carries the weight of the k+1 spheres above it plus the surcharge,
  F_k = (k+1) m g + S, and is loaded along the law's virgin curve to the approach that carries
  it (Newton on fresh contacts), so the motion starts from exact equilibrium.
* Velocity Verlet, time step dt = safety * sqrt(m / k_max) (the chain's highest frequency is below
  2 sqrt(k_max/m), so safety < 1 is stable), k_max the law's largest tangent (loading or
  unloading) at a probe force a few times the static one. A time step given explicitly must not
  exceed the stability limit of the column linearised at k_max (:func:`critical_time_step`).
* Optional damping: P = max(F + c approach', 0) with c = 2 zeta sqrt(m_eff k_tangent), m_eff = m/2
  (m for the base contact), the approach rate from the half-step velocities; never tensile.

Energy is booked in the base frame: kinetic + gravity + surcharge potential + contact work
(trapezoid of F d(approach)) + damping loss - work of the inertial base load is constant up to
the integrator's O(dt^2) error; the law reports how the contact work splits into stored elastic
energy and dissipated (plastic) energy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.constants import g as STANDARD_GRAVITY

from ...errors import ConvergenceError, InputError
from ...schema import finite_number

ContactFactory = Callable[[int], Any]  # n -> an object with the ContactArrays interface
# The paper's column has 5 spheres. The histories keep 4 values per contact and sample (force,
# approach, residual approach, dissipated energy): at the 1 ms default sampling a 40 s record
# on 100 spheres is already ~130 MB in memory and a history.csv of 400 columns.
MAX_SPHERES = 100
# Events of one sequence (main shock + aftershocks): each is a full run of the column and all
# stay in memory; sequences in the literature have a handful.
MAX_AFTERSHOCKS = 20
# Aerogels to osmium; outside it the static column's forces leave the range in which its
# Newton inversion of the virgin curve converges (1e-300 kg/m^3 gave a ConvergenceError).
DENSITY_RANGE = (1.0, 1e5)  # kg/m^3
# Steps of one call of Column.run: each is a Python-level Verlet step (tens of microseconds), so
# 1e8 is about an hour; a time step so small that a record needs more is a typo.
MAX_STEPS_PER_RUN = 10**8


def law_contacts(params) -> ContactFactory:
    """Contacts of the hysteretic law of ``params`` (a :class:`~geocontact.law.LawParams`).
    They do not warn step by step about the law's calibrated range: the column says once,
    after its run, how many went beyond and how deep (``Column.range_excess``)."""
    from ...law import ContactArrays

    return lambda n: ContactArrays(params, n, beyond_range="ignore")


def hertz_contacts(material) -> ContactFactory:
    """Purely elastic Hertz contacts of ``material`` (no dissipation)."""
    from ...law import ContactArrays

    return lambda n: ContactArrays.hertz(material, n)


@dataclass(frozen=True)
class ColumnModel:
    """Geometry, mass and loads of the column."""

    spheres: int
    radius: float
    density: float
    gravity: float = STANDARD_GRAVITY
    surcharge: float = 0.0
    damping_ratio: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.spheres, bool) or not isinstance(self.spheres, int) or self.spheres < 1:
            raise InputError(f"column: number of spheres must be an integer >= 1, got "
                             f"{self.spheres!r}")
        for name in ("radius", "density", "gravity", "surcharge", "damping_ratio"):
            finite_number(name, getattr(self, name))  # no bools, no NaN, no inf
        low, high = DENSITY_RANGE
        if not low <= self.density <= high:
            raise InputError(f"density: must be in [{low:g}, {high:g}] kg/m^3, got "
                             f"{self.density:g}")
        checks = {
            "radius": (self.radius, 0.0, False),
            "gravity": (self.gravity, 0.0, True),
            "surcharge": (self.surcharge, 0.0, True),
            "damping_ratio": (self.damping_ratio, 0.0, True),
        }
        for name, (value, low, allow_equal) in checks.items():
            ok = math.isfinite(value) and (value >= low if allow_equal else value > low)
            if not ok:
                sign = ">=" if allow_equal else ">"
                raise InputError(f"{name}: must be a finite number {sign} {low:g}, got {value:g}")

    @property
    def mass(self) -> float:
        return 4.0 / 3.0 * math.pi * self.radius**3 * self.density

    def static_forces(self) -> np.ndarray:
        """Contact k (from the top) carries the k+1 spheres above it and the surcharge."""
        return (np.arange(self.spheres) + 1.0) * self.mass * self.gravity + self.surcharge


def critical_time_step(mass: float, stiffness: float, spheres: int,
                       damping_ratio: float = 0.0) -> float:
    """Largest stable time step of the column's velocity-Verlet scheme, linearised with every
    contact at the tangent ``stiffness`` (N/m).

    The chain (top sphere free, the bottom one on the fixed base grain) has the stiffness matrix
    k T, T tridiagonal with 1, 2, ..., 2 on the diagonal and -1 beside it, whose eigenvalues are
    4 sin^2((2j - 1) pi / (2 (2N + 1))), j = 1..N: omega_max = 2 sqrt(k/m) sin((2N - 1) pi /
    (2 (2N + 1))), from sqrt(k/m) (one sphere) towards 2 sqrt(k/m) (long columns). Verlet
    (central difference) is stable for omega dt <= 2, and with a modal damping ratio xi for
    omega dt <= 2 (sqrt(1 + xi^2) - xi) (the half-step-velocity damping of ``Column.run`` has
    exactly this limit). The contact dashpots 2 zeta sqrt(m_eff k) give the top mode at most
    xi = zeta sqrt(lambda_max(T)) (the base dashpot, m_eff = m, bounds them all), so with damping
    the value is a safe lower bound of the limit (exact for one sphere and without damping).
    """
    lam = 4.0 * math.sin((2 * spheres - 1) * math.pi / (2 * (2 * spheres + 1))) ** 2
    omega = math.sqrt(lam * stiffness / mass)
    xi = damping_ratio * math.sqrt(lam)
    return 2.0 * (math.sqrt(1.0 + xi * xi) - xi) / omega


def _probe(factory: ContactFactory, n: int):
    """Contacts that measure the law (its virgin curve, its stiffness), not contacts of the
    column: however deep they go, there is nothing to report about the law's calibrated range
    (the column's own contacts report it)."""
    contacts = factory(n)
    if hasattr(contacts, "beyond_range"):
        contacts.beyond_range = "ignore"
    return contacts


def virgin_approach(factory: ContactFactory, forces: np.ndarray, *, rtol: float = 1e-12,
                    max_iter: int = 60) -> np.ndarray:
    """Approaches at which the law's virgin loading curve carries ``forces``.

    Newton on log F(log delta) with fresh contacts each iteration (loading from apart in one step
    follows the virgin curve); exact in one step on a pure power law, so it converges in a few
    iterations on the piecewise power-law curve.
    """
    forces = np.asarray(forces, dtype=float)
    approach = np.zeros_like(forces)
    loaded = forces > 0
    if not loaded.any():
        return approach
    target = forces[loaded]
    guess = np.full(target.shape, 1e-9)
    # bracket: grow the guess until it carries the force (a power law: a few doublings of 10)
    for _ in range(40):
        f, _ = _probe(factory, target.size).step(guess)
        low = f < target
        if not low.any():
            break
        guess = np.where(low, guess * 10.0, guess)
    for _ in range(max_iter):
        f, k = _probe(factory, target.size).step(guess)
        f, k = f.copy(), k.copy()
        if np.all(np.abs(f - target) <= rtol * target):
            approach[loaded] = guess
            return approach
        exponent = np.where((k > 0) & (f > 0), k * guess / np.maximum(f, 1e-300), 1.5)
        step = (np.log(target) - np.log(np.maximum(f, 1e-300))) / np.clip(exponent, 0.1, 10.0)
        guess = guess * np.exp(np.clip(step, -2.0, 2.0))
    raise ConvergenceError(
        f"static column: the virgin curve could not be inverted to {rtol:g} (forces up to "
        f"{target.max():.4g} N)"
    )


@dataclass
class History:
    """Sampled histories (rows = output times)."""

    time: list[float] = field(default_factory=list)
    base_acceleration: list[float] = field(default_factory=list)
    event: list[int] = field(default_factory=list)
    top_displacement: list[float] = field(default_factory=list)
    force: list[np.ndarray] = field(default_factory=list)
    approach: list[np.ndarray] = field(default_factory=list)
    residual_approach: list[np.ndarray] = field(default_factory=list)
    dissipated_energy: list[np.ndarray] = field(default_factory=list)
    kinetic_energy: list[float] = field(default_factory=list)
    energy_error: list[float] = field(default_factory=list)

    def arrays(self) -> dict[str, np.ndarray]:
        return {name: np.asarray(getattr(self, name)) for name in (
            "time", "base_acceleration", "event", "top_displacement", "force", "approach",
            "residual_approach", "dissipated_energy", "kinetic_energy", "energy_error")}


class Column:
    """The column's state and its velocity-Verlet integrator.

    ``factory(n)`` makes the contacts (e.g. :func:`law_contacts`); ``time_step`` overrides the
    automatic one; ``initial_velocity`` (m/s per sphere) perturbs the static start.
    """

    def __init__(self, model: ColumnModel, factory: ContactFactory, *,
                 time_step: float | None = None, safety: float = 0.2,
                 probe_force_factor: float = 3.0, output_interval: float = 1e-3,
                 initial_velocity: np.ndarray | None = None) -> None:
        if not (math.isfinite(safety) and 0 < safety <= 1):
            raise InputError(f"time_step_safety: must be in (0, 1], got {safety:g}")
        if not (math.isfinite(output_interval) and output_interval > 0):
            raise InputError(f"output_interval: must be > 0 s, got {output_interval:g}")
        self.model = model
        n = model.spheres
        self.mass = model.mass
        self.static_force = model.static_forces()
        self.static_approach = virgin_approach(factory, self.static_force)
        self.contacts = factory(n)
        force, stiffness = self.contacts.step(self.static_approach)
        self.force = force.copy()
        self.force_total = force.copy()  # law force + damping, what acts on the spheres
        self.approach = self.static_approach.copy()
        # x_k = -(sum of the approaches below sphere k): x_N = 0 is the base grain
        self.x = -np.cumsum(self.static_approach[::-1])[::-1]
        self.v = np.zeros(n) if initial_velocity is None else np.array(initial_velocity, float)
        if self.v.shape != (n,):
            raise InputError(f"initial_velocity: expected {n} values, got {self.v.shape}")
        self.static_top = float(self.x[0])
        # m_eff = m/2 between two free spheres, m against the base grain
        self.effective_mass = np.full(n, 0.5 * self.mass)
        self.effective_mass[-1] = self.mass
        k_max = self._probe_stiffness(factory, probe_force_factor)
        self.stiffness_estimate = k_max
        limit = critical_time_step(self.mass, k_max, n, model.damping_ratio)
        if time_step is None:
            time_step = safety * math.sqrt(self.mass / k_max)
            if time_step > limit:  # only with strong damping: safety <= 1 is enough without
                raise InputError(
                    f"time_step_safety: {safety:g} gives dt = {time_step:.4g} s, above the "
                    f"stability limit {limit:.4g} s with damping_ratio {model.damping_ratio:g}; "
                    f"must be <= {limit / math.sqrt(self.mass / k_max):.4g}")
        if not (math.isfinite(time_step) and time_step > 0):
            raise InputError(f"time_step: must be a finite number > 0 s, got {time_step:g}")
        if time_step > limit:
            raise InputError(
                f"time_step: must be in (0, {limit:.4g}] s, the stability limit of the explicit "
                f"(velocity Verlet) column at the probe contact stiffness {k_max:.4g} N/m, "
                f"got {time_step:g}")
        self.dt = float(time_step)
        self.stride = max(1, int(round(output_interval / self.dt)))
        self.t = 0.0
        self.steps = 0
        self.max_stiffness_seen = float(np.max(stiffness, initial=0.0))
        self.max_force = self.force.copy()
        # energy book (J)
        self.contact_work = 0.0
        self.damping_loss = 0.0
        self.base_work = 0.0
        self.energy_reference = self._mechanical_energy()
        self.history = History()
        self._sample(0.0, -1)

    # --- set-up -----------------------------------------------------------------------------
    def _probe_stiffness(self, factory: ContactFactory, factor: float) -> float:
        """Largest tangent the contacts are expected to show: loading and unloading stiffness
        at ``factor`` times the static force (or the weight of the column if nothing is
        loaded)."""
        scale = np.maximum(self.static_force, self.model.spheres * self.mass * STANDARD_GRAVITY)
        probe_force = factor * scale
        approach = virgin_approach(factory, probe_force)
        probe = _probe(factory, approach.size)
        _, k_load = probe.step(approach)
        k_load = k_load.copy()
        _, k_unload = probe.step(approach * (1.0 - 1e-9))
        k_max = float(max(np.max(k_load), np.max(k_unload)))
        if not (math.isfinite(k_max) and k_max > 0):
            raise ConvergenceError("column: could not estimate the contact stiffness for dt")
        return k_max

    def _mechanical_energy(self) -> float:
        kinetic = 0.5 * self.mass * float(self.v @ self.v)
        gravity = self.mass * self.model.gravity * float(self.x.sum())
        surcharge = self.model.surcharge * float(self.x[0])
        return kinetic + gravity + surcharge

    def energy_error(self) -> float:
        """Drift of (mechanical + contact work + damping loss - base work) since the start."""
        total = self._mechanical_energy() + self.contact_work + self.damping_loss - self.base_work
        return total - self.energy_reference

    def _sample(self, base_acc: float, event: int) -> None:
        h = self.history
        h.time.append(self.t)
        h.base_acceleration.append(base_acc)
        h.event.append(event)
        h.top_displacement.append(float(self.x[0]))
        h.force.append(self.force.copy())
        h.approach.append(self.approach.copy())
        h.residual_approach.append(np.array(self.contacts.residual_approach, dtype=float))
        h.dissipated_energy.append(np.array(self.contacts.dissipated_energy, dtype=float))
        h.kinetic_energy.append(0.5 * self.mass * float(self.v @ self.v))
        h.energy_error.append(self.energy_error())

    # --- time integration -------------------------------------------------------------------
    def steps_for(self, duration: float) -> int:
        """Time steps to advance by ``duration`` s; an InputError if that is over
        MAX_STEPS_PER_RUN (checked before a run starts, so no progress line precedes it)."""
        if not (math.isfinite(duration) and duration >= 0):
            raise InputError(f"duration: must be >= 0 s, got {duration:g}")
        nsteps = duration / self.dt
        if nsteps > MAX_STEPS_PER_RUN:
            raise InputError(f"time_step: {self.dt:g} s needs {nsteps:.3g} steps for "
                             f"{duration:g} s (at most {MAX_STEPS_PER_RUN:.0e}); raise it or "
                             "time_step_safety")
        return int(math.ceil(nsteps - 1e-9))

    def run(self, duration: float, base_acceleration: Callable[[np.ndarray], np.ndarray]
            | None = None, *, event: int = 0) -> None:
        """Advance by ``duration`` seconds; ``base_acceleration(t)`` (m/s^2, vectorised) is
        the base motion (None: the base is at rest)."""
        nsteps = self.steps_for(duration)
        times = self.t + self.dt * np.arange(nsteps + 1)
        acc_base = (np.zeros(nsteps + 1) if base_acceleration is None
                    else np.asarray(base_acceleration(times), dtype=float))
        m = self.mass
        dt, half_dt2 = self.dt, 0.5 * self.dt * self.dt
        zeta = self.model.damping_ratio
        n = self.model.spheres
        contacts = self.contacts
        x, v = self.x, self.v
        force_total = self.force_total
        a = self._acceleration(force_total, acc_base[0])
        approach = self.approach
        new_approach = np.empty(n)
        rate = np.empty(n)
        power_old = -m * acc_base[0] * float(v.sum())
        k_seen = self.max_stiffness_seen
        max_force = self.max_force
        for i in range(1, nsteps + 1):
            x += v * dt + a * half_dt2
            v_half = v + 0.5 * dt * a
            new_approach[:-1] = x[1:] - x[:-1]
            new_approach[-1] = -x[-1]
            force, stiffness = contacts.step_unchecked(new_approach)
            increment = new_approach - approach
            self.contact_work += 0.5 * float((self.force + force) @ increment)
            if zeta > 0.0:
                rate[:-1] = v_half[1:] - v_half[:-1]
                rate[-1] = -v_half[-1]
                damping = 2.0 * zeta * np.sqrt(self.effective_mass * stiffness)
                damping_old = force_total - self.force
                force_total = self._total_force(force, damping, rate)
                # trapezoid of the damping force over the approach increment, like the contact
                # work, so the energy book stays second-order accurate
                self.damping_loss += 0.5 * float((damping_old + force_total - force) @ increment)
            else:
                force_total = force
            a = self._acceleration(force_total, acc_base[i])
            v[:] = v_half + 0.5 * dt * a
            power = -m * acc_base[i] * float(v.sum())
            self.base_work += 0.5 * (power_old + power) * dt
            power_old = power
            approach[:] = new_approach
            self.force[:] = force
            self.force_total = force_total
            np.maximum(max_force, force, out=max_force)
            k_step = float(stiffness.max())
            if k_step > k_seen:
                k_seen = k_step
            self.steps += 1
            self.t = float(times[i])
            if self.steps % self.stride == 0:
                self._sample(float(acc_base[i]), event)
            if not math.isfinite(x[0]):
                raise ConvergenceError(f"column: the integration diverged at t = {self.t:.6g} s "
                                       f"(dt = {dt:.3g} s); lower time_step_safety")
        self.max_stiffness_seen = k_seen

    def range_excess(self):
        """The column's contacts beyond their law's calibrated depth so far (count, largest
        depth; ``geocontact.law.calibrated_range``), None if none is (or plain Hertz)."""
        excess = getattr(self.contacts, "range_excess", None)
        return None if excess is None else excess()

    @staticmethod
    def _total_force(force: np.ndarray, damping: np.ndarray, rate: np.ndarray) -> np.ndarray:
        """Law force plus viscous damping while in contact; never tensile."""
        return np.where(force > 0.0, np.maximum(force + damping * rate, 0.0), 0.0)

    def _acceleration(self, force_total: np.ndarray, base_acc: float) -> np.ndarray:
        above = np.empty_like(force_total)
        above[0] = self.model.surcharge
        above[1:] = force_total[:-1]
        return (force_total - above) / self.mass - self.model.gravity - base_acc

    # --- results ----------------------------------------------------------------------------
    @property
    def stability_ratio(self) -> float:
        """dt * sqrt(k_max_seen / m): the explicit scheme is stable below 1."""
        return self.dt * math.sqrt(self.max_stiffness_seen / self.mass)

    def settlement(self) -> float:
        """Downward displacement of the top sphere relative to the base since the static start."""
        return self.static_top - float(self.x[0])
