"""The design of record of the universal law's campaign (issue 37): the widened material space,
levels defined by the contact size, the repeated history at every point, the FE of record.

Beside today's design (``design``: 4 axes, levels in multiples of Fy, coarse mesh, small strain,
no repeated history), which keeps the shipped dataset working. Select it with
``python -m geocontact.universal.campaign --design record``.

* **Axes** (``AXES``): beta 0-60 deg, nu 0.1-0.4, m 0-0.3, E/sigma_c 30-1e5 (log axis): what
  rock and soil grains span, from soft crushable grains to quartz at its contact yield stress.
* **Points**: the same deterministic construction as today's (``design.unit_sequence``: centre,
  the half-fraction corners, 8 scrambled Sobol points, the other corners, Sobol on).
* **Levels by contact size.** A point's levels are not multiples of Fy (that stopped weak grains
  at a/R 0.005-0.02) but contact radii: ``LEVELS`` targets geometric in a/R from a_low, the
  contact radius of the lowest calibration peak (2 Fy, ``lowest_peak_over_yield``: the first
  plastic level ``geocontact calibrate`` accepts), to the top target
  min(max(0.3 R, 2 a_low), 0.45 R) (``top_target``: E/sigma_c ~ 30 with steep friction yields
  at a/R ~ 0.16, its lowest level is at 0.2 R already), or what the FE reached where that is
  less. The force of a target radius is read off an FE *probe* of the point (a monotonic
  loading with the point's FE settings; its ``contact_radius_m`` curve): no pressure model is
  assumed, so the rule holds for every beta, m and E/sigma_c. The levels are what the FE then
  reached: each level's achieved a/R (at its peak) is in the dataset row, and the levels are
  indexed by their position u = k / (LEVELS - 1) between the lowest peak and the top, so that
  rows are comparable across E/sigma_c.
* **Validity limit**: the FE mesh's refined zone, a <= R/2 (``fem.mesh.build_mesh`` clips its
  contact zone there). The campaign's first probe goes to the force at which an upper *estimate*
  of the contact radius reaches R/2 (``fem.run.largest_contact_radius_estimate``: 1.2 x Hertz's
  or a mean pressure of 2.5 sigma_c; the FE commands' own bound until they stopped at the
  measured contact instead, ``fem.limits.check_resolved_force``), which for a hardening or
  pressure-sensitive grain is far too cautious (the pilot's centre point carries 24 sigma_c at
  a/R = 0.13, where that estimate stops it). The campaign therefore measures the contact
  instead: the first probe goes to that force (``validity_force``), and while the probe's
  contact is below the top target the next probe goes to the force that carries 1.1 x the
  target at the mean pressure the last one reached (``next_probe_force``, at most
  ``MAX_PROBES``, never aimed beyond R/2). The top is the smaller of the target and the last
  probe's contact.
* **Per point**: the probe, the ``LEVELS`` calibration runs (``calibrate``'s shape 0 -> F -> 0 ->
  F -> 0, one mesh sized for the top) and the paper's repeated history at
  ``cyclic_peak_over_max`` x the top peak (``calibrate.campaign.cyclic_job``'s), so the cyclic
  extension is interpolated like the rest.
* **FE settings**: one ``fem.settings.FeSettings`` (``fe_settings``): the default mesh, finite
  strain everywhere (at a/R up to 0.3 it matters, docs/verification/finite_strain_ccx_weak.md)
  on the compiled kernels, the FE's other defaults; mesh and kinematics overridable for pilots.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import InputError
from ..fem.campaign import FemJob
from ..fem.settings import FeSettings
from ..grain.hertz import incipient_yield
from ..grain.material import Material
from .design import (
    CAMPAIGN_MODULUS,
    CAMPAIGN_RADIUS,
    SOBOL_SEED,
    DesignPoint,
    unit_sequence,
)

NAME = "record"
AXES = (
    ("friction_angle_deg", 0.0, 60.0),
    ("poissons_ratio", 0.1, 0.4),
    ("hardening_ratio", 0.0, 0.3),
    ("log10_modulus_over_strength", math.log10(30.0), 5.0),
)
AXIS_NAMES = tuple(a[0] for a in AXES)
LEVELS = 7
TOP_CONTACT_OVER_RADIUS = 0.3
# the FE's validity limit: the mesh's refined zone, a <= R/2 (fem.mesh.build_mesh clips there)
VALID_CONTACT_OVER_RADIUS = 0.5
MIN_POINTS_OF_RECORD = 64
# Probes: aim 10 % beyond the top radius (the mean pressure may still rise), at most MAX_PROBES
PROBE_AIM = 1.1
# A probe the FE cannot finish (point 5 of the design: E/sigma_c 1e5, beta 60 deg, nu 0.1, m 0;
# every point of the grain yielded from 262 N on, the contact ran away, Newton failed at 1221 N on
# the coarse mesh): the base stops at this fraction of the probe's last converged force, and the
# point's top level is the contact the base reaches (docs/universal.md, "Grains the FE cannot
# load to the top").
FAILED_PROBE_FORCE = 0.9
MAX_PROBES = 4
# The top spans at least a doubling of the lowest level's contact radius, within 0.45 R
MIN_SPAN = 2.0
TOP_CAP = 0.45


# The FE settings the pilot (datasets/universal/record-pilot) was computed with: the coarse mesh
# and the "yield" meshes with fixed load steps, the FE defaults of its day. Named, so the pilot's
# runs are found and its figures regenerate after issue 36 moved the defaults.
PILOT_FE = {"mesh": "coarse", "mesh_rule": "yield", "step_control": "fixed",
            "step_rule": "segment", "newton": "full"}


# The step control of the campaign of record's runs (docs/universal.md "The campaign of record").
RECORD_STEP_CONTROL = "envelope"
# Its Newton updates: backtracked (docs/fem.md "Backtracking"). The design's hard, perfectly plastic
# corner (E/sigma_c near 1e5, m near 0) stalls with full updates; a solve whose full updates all
# lower the residual is the same with it, bit for bit.
RECORD_NEWTON = "backtracking"


def fe_settings(mesh: str = "default", kinematics: str = "finite", **changes) -> FeSettings:
    """The FE of record: ``mesh`` (default mesh), ``kinematics`` (finite strain), the compiled
    kernels (small or finite strain), the "envelope" step control (the "dissipation" control,
    the FE's verified default of issue 36, with a reload over the flattened dent measured
    against itself: the same solves on the base's ramp, resolved to "dissipation" there; on the
    repeated history 0.7 of its CPU, within 2.0 % of a step-converged reference in every
    cycle's plastic work and ratchet, docs/fem.md "The envelope control"), backtracked Newton
    updates (``RECORD_NEWTON``, docs/fem.md "Backtracking") and every other
    setting the FE's default (the mesh rule "auto"); ``changes``: any other FeSettings field
    (``PILOT_FE`` for the pilot's). One-line InputError on a setting the FE refuses. The
    load steps follow the "decade" rule: the levels are branches of the base run at its
    recorded steps (``level_steps``), and at least 12 loading steps per decade of force
    (1.21 x apart) put each within about 5 % of its target contact radius."""
    changes.setdefault("kernels", "compiled")
    changes.setdefault("step_rule", "decade")
    changes.setdefault("step_control", RECORD_STEP_CONTROL)
    changes.setdefault("newton", RECORD_NEWTON)
    return FeSettings(mesh=mesh, kinematics=kinematics, **changes)


def job(material: Material, forces, settings: FeSettings, label: str,
        mesh_force: float | None = None, *, follows=None, snapshots: bool = False) -> FemJob:
    """One FE run of a point with ``settings`` (``mesh_force`` sizes the mesh, None: its own;
    ``follows``: a branch, ``snapshots``: saved for branches; ``fem.campaign.FemJob``)."""
    fields = {name: getattr(settings, name) for name in FeSettings.names()}
    fields["mesh_force"] = mesh_force
    return FemJob(material, tuple(float(f) for f in forces), label=label, follows=follows,
                  snapshots=snapshots, **fields)


# A point of the design of record has today's four coordinates (the same names, the same
# material at them); only the box they are drawn from differs.
RecordPoint = DesignPoint


def from_unit(u) -> np.ndarray:
    low = np.array([a[1] for a in AXES])
    high = np.array([a[2] for a in AXES])
    return low + np.asarray(u, dtype=float) * (high - low)


def unit(coordinates) -> np.ndarray:
    low = np.array([a[1] for a in AXES])
    high = np.array([a[2] for a in AXES])
    return (np.asarray(coordinates, dtype=float) - low) / (high - low)


def design_points(count: int) -> list[RecordPoint]:
    """The first ``count`` points of the design of record (today's sequence on the new box)."""
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 4096:
        raise InputError(f"points: need an integer in [1, 4096], got {count!r}")
    coords = from_unit(unit_sequence(count, len(AXES)))
    return [RecordPoint(i, *(float(v) for v in c)) for i, c in enumerate(coords)]


def outside_range(material: Material) -> list[str]:
    """One message per coordinate of ``material`` outside the box of record (empty: inside)."""
    from .design import coordinates_of

    out = []
    for (name, low, high), value in zip(AXES, coordinates_of(material), strict=True):
        tol = 1e-9 * max(1.0, abs(high - low))
        if low - tol <= value <= high + tol:
            continue
        if name == "log10_modulus_over_strength":
            out.append(f"youngs_modulus / compressive_yield_stress: {10**value:.4g} is outside "
                       f"the universal law's range [{10**low:.4g}, {10**high:.4g}]")
        else:
            out.append(f"{name}: {value:g} is outside the universal law's range "
                       f"[{low:g}, {high:g}]")
    return out


# --- the level rule --------------------------------------------------------------------------
def validity_force(material: Material) -> float:
    """The force at which the upper estimate of the contact radius reaches R/2
    (``largest_contact_radius_estimate``; the FE commands' bound before they stopped at the
    measured contact), by bisection in log F on that same estimate (it grows with F)."""
    from ..fem.run import largest_contact_radius_estimate

    bound = VALID_CONTACT_OVER_RADIUS * material.radius
    low = high = incipient_yield(material).force
    while largest_contact_radius_estimate(material, high) <= bound:
        low, high = high, high * 10.0
    while largest_contact_radius_estimate(material, low) > bound:
        low, high = low / 10.0, low
    for _ in range(80):
        mid = math.sqrt(low * high)
        low, high = (mid, high) if largest_contact_radius_estimate(material, mid) <= bound \
            else (low, mid)
    return low


# The probes that find a point's forces only place the base's force (``base_force``), whose own
# curve then places the levels: they run on the pilot's settings (coarse mesh, "yield" meshes,
# fixed steps; 5-12 s a probe in the pilot), a few per cent off the FE of record in a(F), which
# moves only where the base ends (aimed at 1.1 x the top target). On the FE of record's own
# controls a coarse probe took 7 min (the centre point's first, to 78.7 kN).
PROBE_MESH = "coarse"


def probe_settings(settings: FeSettings) -> FeSettings:
    """The FE settings of a point's probes: the point's, with the pilot's mesh, mesh rule, step
    control and step rule (``PILOT_FE``)."""
    from dataclasses import replace

    return replace(settings, **PILOT_FE)


def probe_job(point: RecordPoint, settings: FeSettings, force: float | None = None,
              attempt: int = 0) -> FemJob:
    """A probe of the point: one monotonic loading to ``force`` (default the first probe's, the
    FE's validity force ``validity_force``), whose contact radius curve places the base's force
    (``base_force``)."""
    material = point.material()
    top = validity_force(material) if force is None else float(force)
    return job(material, (0.0, top), settings, f"record probe {attempt} F={top:.4g}N")


def base_force(material: Material, force, radius, *, failed: bool = False) -> float:
    """The force of the point's base run (``base_job``): the one that carries ``PROBE_AIM`` x the
    top target radius (never more than R/2) on the probes' a(F) (``contact_curve``), by log-log
    interpolation where the probes reach it, else at the mean pressure of the last probe's top
    (as ``next_probe_force`` aims). ``failed``: the last probe is the converged part of one the
    FE could not finish (``record_campaign.FailedRun``): the base goes no further than
    ``FAILED_PROBE_FORCE`` x its last converged force, so the FE of record is not driven into
    the failure; the top level is then the contact the base reaches (``level_forces``)."""
    force, radius = np.asarray(force, float), np.asarray(radius, float)
    aim = min(PROBE_AIM * top_target(material, force, radius),
              VALID_CONTACT_OVER_RADIUS * material.radius)
    if failed:
        reach = FAILED_PROBE_FORCE * float(force[-1])
        if radius[-1] < aim:
            return reach
        unique, first = np.unique(np.log(radius), return_index=True)
        return min(reach, float(np.exp(np.interp(math.log(aim), unique, np.log(force)[first]))))
    if radius[-1] >= aim:
        unique, first = np.unique(np.log(radius), return_index=True)
        return float(np.exp(np.interp(math.log(aim), unique, np.log(force)[first])))
    return float(math.pi * aim ** 2 * force[-1] / (math.pi * radius[-1] ** 2))


def base_job(point: RecordPoint, settings: FeSettings, force: float) -> FemJob:
    """The point's base run: one monotonic loading to ``force`` on the FE of record, saving its
    snapshots; its curve places the levels, which branch from it (``point_jobs``)."""
    material = point.material()
    return job(material, (0.0, float(force)), settings, f"record base F={force:.4g}N",
               snapshots=True)


def next_probe_force(material: Material, force, radius) -> float | None:
    """The force of the next probe when this one (``contact_curve``) stopped short of the top
    contact radius; None when it reached it. The FE's validity estimate assumes a mean pressure
    of 2.5 sigma_c; a hardening or pressure-sensitive grain carries far more (24 sigma_c at a/R
    0.13 for beta 30 deg, m 0.15: the pilot), so its first probe reaches a/R 0.1-0.15 only. The
    next probe is loaded to the force that carries ``PROBE_AIM`` x the top radius at the mean
    pressure this probe reached at its top (a contact whose mean pressure still rises, under
    hardening, ends a little short of it; one more probe then)."""
    force, radius = np.asarray(force, float), np.asarray(radius, float)
    target = top_target(material, force, radius)
    if radius[-1] >= target * (1.0 - 1e-9):
        return None
    pressure = force[-1] / (math.pi * radius[-1] ** 2)
    aim = min(PROBE_AIM * target, VALID_CONTACT_OVER_RADIUS * material.radius)
    return float(math.pi * aim ** 2 * pressure)


def lowest_force(material: Material) -> float:
    """The lowest level's force: ``lowest_peak_over_yield`` x the analytic Fy (calibrate's)."""
    from ..calibrate.campaign import settings as calibration_settings

    fy = incipient_yield(material).force
    return float(calibration_settings()["campaign"]["lowest_peak_over_yield"]) * fy


def lowest_contact(material: Material, force, radius) -> tuple[float, float]:
    """The lowest level's force (``lowest_peak_over_yield`` x Fy) and its contact radius on a
    probe's loading (log-log interpolation). Below the probe's first loaded step (a probe
    whose load schedule starts above 2 Fy: point 5's first step is at 2.4 Fy) the contact
    radius is Hertz's: at 2 Fy the plastic zone is a small core, and where the FE runs of the
    campaign span 2 Fy their contact there is 0.984-1.011 x Hertz's on 17 of 18 runs (the
    18th, a coarse probe at E/sigma_c 1e5, resolves a/R 1e-5 poorly: 0.94; docs/universal.md)."""
    from ..grain.hertz import contact_radius, hertz_approach

    force, radius = np.asarray(force, float), np.asarray(radius, float)
    if force.size < 2:
        raise InputError("record levels: the probe has fewer than 2 loaded steps with a contact")
    low_force = lowest_force(material)
    if not low_force <= force[-1]:
        raise InputError(f"record levels: the probe spans {force[0]:.4g}-{force[-1]:.4g} N, "
                         f"not the lowest peak {low_force:.4g} N")
    if low_force < force[0]:
        return low_force, float(contact_radius(material, hertz_approach(material, low_force)))
    return low_force, float(np.exp(np.interp(math.log(low_force), np.log(force),
                                              np.log(radius))))


def top_target(material: Material, force, radius) -> float:
    """The top level's target contact radius (m): 0.3 R, or ``MIN_SPAN`` x the lowest level's
    where that is larger (E/sigma_c ~ 30 with steep friction yields at a/R ~ 0.16: its lowest
    level is at 0.2 R already), never beyond ``TOP_CAP`` x R (the mesh's refined zone ends at
    R/2)."""
    a_low = lowest_contact(material, force, radius)[1]
    return min(max(TOP_CONTACT_OVER_RADIUS * material.radius, MIN_SPAN * a_low),
               TOP_CAP * material.radius)


def contact_curve(*curves: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Force and contact radius of one or more monotonic loadings of a point (``curve.csv``
    columns: its probes), merged in force order, the radius made non-decreasing (the contact
    only grows; a node engaging, or two probes' meshes, can make it dip). Merging matters for
    weak grains: a probe loaded to 10^11 Fy takes its first steps far above Fy and its mesh does
    not resolve a contact there (E/sigma_c = 1e5: a = 0 at 0.8 and 0.95 Fy, first contact at
    350 Fy), while the first probe, loaded 10^9 times less far, has the low forces."""
    force = np.concatenate([np.asarray(c["force_N"], float) for c in curves])
    radius = np.concatenate([np.asarray(c["contact_radius_m"], float) for c in curves])
    keep = (force > 0.0) & (radius > 0.0)
    order = np.argsort(force[keep], kind="stable")
    return force[keep][order], np.maximum.accumulate(radius[keep][order])


def level_forces(material: Material, force, radius) -> dict[str, Any]:
    """The level rule on a probe's loading (``contact_curve``): targets geometric in a from the
    contact radius at ``lowest_peak_over_yield`` x Fy to min(0.3 R, the probe's largest), the
    force of each by log-log interpolation of a(F). Returns the forces, the target a/R and the
    top's reason."""
    force, radius = np.asarray(force, float), np.asarray(radius, float)
    low_force, a_low = lowest_contact(material, force, radius)
    logf, loga = np.log(force), np.log(radius)
    a_reached = float(radius[-1])
    target = top_target(material, force, radius)
    a_top = min(target, a_reached)
    if a_top <= a_low * 1.5:
        raise InputError(f"record levels: the probe's contact grows only from {a_low:.3g} to "
                         f"{a_top:.3g} m; not enough for {LEVELS} levels")
    targets = np.geomspace(a_low, a_top, LEVELS)
    # a(F) is monotone: F(a) is the inverse interpolation; flat parts (a node not yet engaged)
    # take their first force
    unique, first = np.unique(loga, return_index=True)
    forces = np.exp(np.interp(np.log(targets), unique, logf[first]))
    forces[0] = low_force
    return {"forces_N": [float(f) for f in forces],
            "target_contact_over_radius": [float(a / material.radius) for a in targets],
            "top": (f"{target / material.radius:.3g} R" if a_top < a_reached else
                    f"the largest contact the FE reached, {a_reached / material.radius:.3g} R")}


def level_steps(forces, base_curve: dict[str, np.ndarray]) -> tuple[list[int], list[float]]:
    """The recorded loading steps of the base probe (``curve.csv`` of a ramp 0 -> F) nearest
    in log F to ``forces``, and their forces: a level is a branch of the probe at one of its
    steps. Two forces on one step is a one-line InputError (the probe's steps too coarse)."""
    curve = np.asarray(base_curve["force_N"], float)
    steps = np.nonzero(curve > 0.0)[0]
    chosen = [int(steps[np.argmin(np.abs(np.log(curve[steps]) - math.log(f)))]) for f in forces]
    if len(set(chosen)) != len(chosen):
        raise InputError(f"record levels: the probe's recorded steps are too far apart for "
                         f"{len(chosen)} levels (steps {chosen})")
    return chosen, [float(curve[k]) for k in chosen]


def point_jobs(point: RecordPoint, settings: FeSettings, levels: dict[str, Any],
               base: FemJob, base_curve: dict[str, np.ndarray]
               ) -> tuple[list[FemJob], FemJob]:
    """The calibration runs at the levels (calibrate's history shape 0 -> F -> 0 -> F -> 0) and
    the repeated-history run at ``cyclic_peak_over_max`` x the top, each a branch of the point's
    base run ``base`` (its curve ``base_curve``) at the recorded step nearest its force
    (``level_steps``): they share its mesh and its loading up to their peak, and the campaign
    computes only what comes after (docs/fem.md "Branches of a run"). ``levels`` gains the
    steps and the forces taken ("forces_N"; the rule's own under "rule_forces_N")."""
    from ..calibrate.campaign import settings as calibration_settings
    from ..grain.force_history import preset_history

    campaign = calibration_settings()["campaign"]
    material = point.material()
    cyclic_target = float(campaign["cyclic_peak_over_max"]) * max(levels["forces_N"])
    steps, peaks = level_steps([*levels["forces_N"], cyclic_target], base_curve)
    levels.setdefault("rule_forces_N", list(levels["forces_N"]))
    levels.update(forces_N=peaks[:-1], base_steps=steps[:-1], base_key=base.key())
    runs = [job(material, [float(s) * peak for s in campaign["history"]], settings,
                f"record level {k} F={peak:.4g}N", base.mesh_force,
                follows=(base.forces, step))
            for k, (step, peak) in enumerate(zip(steps[:-1], peaks[:-1], strict=True))]
    cyclic = job(material, preset_history(campaign["cyclic_history"], peaks[-1]), settings,
                 f"record {campaign['cyclic_history']} F={peaks[-1]:.4g}N", base.mesh_force,
                 follows=(base.forces, steps[-1]))
    return runs, cyclic


def describe() -> dict[str, Any]:
    """The design of record as provenance.json records it."""
    return {
        "name": NAME,
        "axes": [{"name": a[0], "low": a[1], "high": a[2]} for a in AXES],
        "sequence": "centre of the box, 8 corners (half fraction x4 = x1 x2 x3), 8 scrambled "
                    f"Sobol points (scipy.stats.qmc, seed {SOBOL_SEED}), the other 8 corners, "
                    "then Sobol on",
        "modulus_Pa": CAMPAIGN_MODULUS, "radius_m": CAMPAIGN_RADIUS,
        "levels": f"{LEVELS} targets geometric in a/R from the contact radius a_low at the "
                  "lowest calibration peak (2 Fy) to min(the top target, the base run's "
                  f"largest contact), top target = min(max({TOP_CONTACT_OVER_RADIUS} R, "
                  f"{MIN_SPAN} a_low), {TOP_CAP} R); forces read off the base run's a(F)",
        "probes": f"monotonic loadings on the {PROBE_MESH} mesh: the first to the FE "
                  "commands' force bound (fem.limits: a <= R/2 by the 2.5 sigma_c estimate), "
                  f"each next one to the force carrying {PROBE_AIM} x {TOP_CONTACT_OVER_RADIUS} "
                  f"R at the mean pressure the last reached, at most {MAX_PROBES}; validity "
                  "limit: the mesh's refined zone, a <= R/2",
        "base": f"one monotonic loading on the FE of record to the force carrying {PROBE_AIM} "
                "x the top target on the probes' a(F); its a(F) places the levels",
        "repeated_history": "calibration.toml cyclic_history at cyclic_peak_over_max x the top "
                            "level's force",
        "branches": "the levels and the repeated history are branches of the base "
                    "(fem.run follows) at its recorded loading step nearest their force "
                    "(step rule 'decade': >= 12 loading steps per decade), on its mesh",
    }
