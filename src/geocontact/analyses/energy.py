"""The energy ledger of a LAMMPS run with ``pair_style geocontact`` and ``fix wall/geocontact``
(docs/dem.md "Energy ledger"): where the work of the boundaries went.

Over any interval, the work W the moving walls did on the grains (and gravity's, if it acts)
equals the change of the kinetic energy K of the grains, plus the change of the energy U stored
in the contacts' springs (normal: the law; tangential, rolling, twisting), plus what the
contacts dissipated D (the law, Coulomb sliding, the normal and tangential dashpots, rolling,
twisting):

    W = dK + dU + D

The plugin tallies every channel of U and D per contact, inside its one contact step, for the
pair and the walls alike (``compute pair geocontact`` and the walls' global vectors; the
indices below, docs/interfaces.md); the walls tally their own work, the sum over steps of the
contact force on the grain times the wall's velocity. The closure residual W - dK - dU - D is
the error of the time integration (velocity Verlet: the force's work over a step is not exactly
the change of the kinetic energy) and of the explicit force updates; it is reported.

``energy_ledger(lmp, ...)`` reads the channels from a running LAMMPS (``lammps.lammps``, on
every rank: its sums are over ranks), ``ledger_change(start, end)`` makes the ledger of an
interval (the object ``energy`` of ``geocontact dem``'s summary.json), ``read_ledger_table``
reads the rows examples/lammps/ledger.lmp writes. Energies are in the run's units (J under
``units si``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

# compute pair geocontact: 0-based indices of its global vector (pair_geocontact.h GlobalValue)
PAIR_INDEX = {
    "dissipated": {"law": 0, "sliding": 6, "normal_damping": 7, "tangential_damping": 8,
                   "rolling": 9, "twisting": 10},
    "stored": {"normal": 1, "tangential": 12, "rolling": 13, "twisting": 14},
    "of_which_contact_radius": 11,
    "of_which_memory_reset": 17,
}
# fix wall/geocontact: 0-based indices of its global vector (fix_wall_geocontact.h Global)
WALL_INDEX = {
    "dissipated": {"law": 3, "sliding": 8, "normal_damping": 9, "tangential_damping": 10,
                   "rolling": 11, "twisting": 12},
    "stored": {"normal": 4, "tangential": 14, "rolling": 15, "twisting": 16},
    "of_which_contact_radius": 13,
    "boundary_work": 17,
    "of_which_memory_reset": 20,
}
STORED = tuple(PAIR_INDEX["stored"])
DISSIPATED = tuple(PAIR_INDEX["dissipated"])


def kinetic_energy(lmp) -> float:
    """1/2 m v^2 + 1/2 I w^2 of every grain (solid spheres, I = 2/5 m r^2), gathered over
    ranks (every rank must call it)."""
    n = lmp.get_natoms()
    if n == 0:
        return 0.0
    v = np.ctypeslib.as_array(lmp.gather_atoms("v", 1, 3), shape=(n * 3,)).reshape(n, 3)
    w = np.ctypeslib.as_array(lmp.gather_atoms("omega", 1, 3), shape=(n * 3,)).reshape(n, 3)
    m = np.ctypeslib.as_array(lmp.gather_atoms("rmass", 1, 1), shape=(n,))
    r = np.ctypeslib.as_array(lmp.gather_atoms("radius", 1, 1), shape=(n,))
    translation = 0.5 * np.sum(m * np.sum(v * v, axis=1))
    rotation = 0.5 * np.sum(0.4 * m * r * r * np.sum(w * w, axis=1))
    return float((translation + rotation) * lmp.extract_global("mvv2e"))


def energy_ledger(lmp, pair: str | None = "law", walls: tuple[str, ...] = (),
                  gravity_work: float = 0.0) -> dict:
    """The cumulative channels of a running LAMMPS now: the boundary work of the walls (their
    own tally since they were defined), the kinetic energy, the stored and the dissipated
    energies summed over the pair's compute ``pair`` (``compute ID all pair geocontact``; None:
    no pair) and the walls ``walls`` (fix IDs of fix wall/geocontact). Call it between runs,
    after a step on which the pair tallied energy (the last step of a run, with thermo output
    on it, as LAMMPS does by default). ``gravity_work``: the work gravity did, if it acts (the
    caller's, e.g. -change of sum m g z)."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    stored = dict.fromkeys(STORED, 0.0)
    dissipated = dict.fromkeys(DISSIPATED, 0.0)
    radius_part = reset_part = 0.0
    work = 0.0
    sources = []
    if pair is not None:
        sources.append((lambda k: lmp.extract_compute(pair, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[k],
                        PAIR_INDEX))
    for wall in walls:
        sources.append((lambda k, f=wall: lmp.extract_fix(f, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR,
                                                           k, 0), WALL_INDEX))
    for value, index in sources:
        for name, k in index["stored"].items():
            stored[name] += value(k)
        for name, k in index["dissipated"].items():
            dissipated[name] += value(k)
        radius_part += value(index["of_which_contact_radius"])
        reset_part += value(index["of_which_memory_reset"])
        if "boundary_work" in index:
            work += value(index["boundary_work"])
    return {"boundary_work": work, "gravity_work": gravity_work, "kinetic": kinetic_energy(lmp),
            "stored": stored, "dissipated": dissipated, "of_which_contact_radius": radius_part,
            "of_which_memory_reset": reset_part}


def ledger_change(start: dict, end: dict) -> dict:
    """The ledger of the interval from ``start`` to ``end`` (two ``energy_ledger`` values or
    rows of ``read_ledger_table``): the object ``energy`` of summary.json, with the closure
    residual W - dK - dU - D and its fraction of the boundary work."""
    work = end["boundary_work"] - start["boundary_work"]
    gravity = end.get("gravity_work", 0.0) - start.get("gravity_work", 0.0)
    kinetic = end["kinetic"] - start["kinetic"]
    stored = {k: end["stored"][k] - start["stored"][k] for k in STORED}
    dissipated = {k: end["dissipated"][k] - start["dissipated"][k] for k in DISSIPATED}
    residual = work + gravity - kinetic - sum(stored.values()) - sum(dissipated.values())
    energy = {"boundary_work_J": work}
    if gravity:
        energy["gravity_work_J"] = gravity
    energy.update({
        "change_kinetic_J": kinetic,
        "change_stored_J": stored,
        "dissipated_J": dissipated,
        # part of sliding and twisting: the springs' energy released by the change of the
        # contact radius (contact_forces.h LedgerChannel)
        "of_which_contact_radius_change_J":
            end["of_which_contact_radius"] - start["of_which_contact_radius"],
        # part of the law's: the normal elastic energy the dents `memory place` forgot held
        # less what the fresh states took over (>= 0: forgetting never creates energy;
        # docs/dem.md "Memory with a place"); 0 under memory pair
        "of_which_memory_reset_J":
            end.get("of_which_memory_reset", 0.0) - start.get("of_which_memory_reset", 0.0),
        # the tangential contact's whole dissipation: where the dashpot's force alone exceeds
        # the Coulomb limit, the slip reset stores the spring along the sliding velocity (as
        # LAMMPS's granular models do) and the split between the two is the model's, with
        # sliding negative (docs/dem.md "Energy ledger"); their sum is the energy lost
        "tangential_total_J": dissipated["sliding"] + dissipated["tangential_damping"],
        "closure_residual_J": residual,
        "closure_residual_fraction": residual / abs(work + gravity) if work + gravity else None,
    })
    return energy


def read_ledger_table(path: Path) -> dict[str, dict]:
    """The rows of a ledger.txt (examples/lammps/ledger.lmp), by label, as ``energy_ledger``
    values (a repeated label: its last row)."""
    lines = Path(path).read_text().splitlines()
    names = lines[0].lstrip("#").split()
    rows = {}
    for line in lines[1:]:
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.split()
        value = dict(zip(names[1:], (float(f) for f in fields[1:]), strict=True))
        rows[fields[0]] = {
            "step": int(value["step"]),
            "boundary_work": value["boundary_work_J"],
            "kinetic": value["kinetic_J"],
            "stored": {k: value[f"stored_{k}_J"] for k in STORED},
            "dissipated": {k: value[f"dissipated_{k}_J"] for k in DISSIPATED},
            "of_which_contact_radius": value["of_which_contact_radius_J"],
            # a ledger.txt written before the column: no memory resets counted
            "of_which_memory_reset": value.get("of_which_memory_reset_J", 0.0),
        }
    return rows
