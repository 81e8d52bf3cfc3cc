"""Golden test vectors of the law for other implementations (the C++ header in plugins/lammps).

Random approach histories (deterministic seed) run through the scalar reference ``Contact``; the
approaches in, and the forces, stiffnesses, branches and final states out, are written to one
JSON file that the C++ test (``plugins/lammps/tests/test_golden.cpp``) replays. Regenerate with::

    python scripts/make_golden_vectors.py --out plugins/lammps/tests/golden.json

Never edit the output by hand. Each case embeds its parameter document, so the file is
self-contained. The history families cover what a DEM contact meets: random walks with
separation and re-contact, partial reversals at every depth, deep plastic excursions beyond
the fully plastic approach, many cycles to one peak with the cyclic (ratchet) extension on, and
repeated cycles to the envelope point itself, exact or jittered by 1e-9 (the envelope band).
The parameter variants include every optional form: the cyclic extension on and off, the
transition depth, the third loading regime and log power, the shakedown form, and a tabulated
residual approach.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np

from geocontact.errors import ArgumentParser, InputError, run_reporting_errors
from geocontact.files import check_output_file, write_text_atomic
from geocontact.law.calibrated_range import IGNORE
from geocontact.law.params import LawParams, load_params
from geocontact.law.reference import Contact

GOLDEN_SCHEMA = "geocontact.golden/1"
# relative to the working directory (the repository root, where the generator is run): the
# installed package does not know where a checkout is
DEFAULT_PARAMS = Path("examples") / "params-illustrative.json"
SEED = 20250722
# Histories per family, split over the parameter variants: the shipped file uses 60 (10 per
# variant; a variant added at the end with the count per variant kept leaves the earlier
# variants' histories as they were); 10000 already makes a file of ~100 MB.
PER_FAMILY = 60
MAX_PER_FAMILY = 10000
STATE_KEYS = ("approach", "force", "max_approach", "max_force", "residual_approach",
              "unloading_exponent", "reloading_exponent", "branch", "branch_value",
              "ratchet_shift", "pending_ratchet", "cycles", "work")


def _sample(rng: np.random.Generator, targets: list[float], max_substeps: int) -> list[float]:
    """Piecewise-linear path through the targets, each leg cut into 1..max_substeps steps
    (one step may cross several branch ends, as a coarse DEM step does)."""
    path = []
    start = 0.0
    for end in targets:
        n = int(rng.integers(1, max_substeps + 1))
        path += [start + (end - start) * (k + 1) / n for k in range(n)]
        start = end
    return path


def _random_walk(rng, dy):
    """Loads and unloads of random depth, with separations (negative approach) and re-contact."""
    targets = []
    for _ in range(int(rng.integers(3, 9))):
        targets.append(float(rng.uniform(-2.0, 60.0)) * dy)
    return _sample(rng, targets, 8)


def _partial_reversals(rng, dy):
    """A deep load, then reversals between random force levels on the same envelope."""
    peak = float(rng.uniform(2.0, 40.0)) * dy
    targets = [peak]
    for _ in range(int(rng.integers(4, 12))):
        targets.append(float(rng.uniform(0.0, 1.0)) * peak)
    targets.append(peak * float(rng.uniform(1.0, 1.5)))
    targets.append(float(rng.uniform(-0.5, 0.5)) * peak)
    return _sample(rng, targets, 6)


def _deep_plastic(rng, dy):
    """Excursions far beyond the fully plastic approach, unloading to separation between."""
    targets = []
    level = float(rng.uniform(20.0, 200.0)) * dy
    for _ in range(int(rng.integers(2, 5))):
        targets += [level, float(rng.uniform(-1.0, 0.6)) * level]
        level *= float(rng.uniform(1.2, 5.0))
    return _sample(rng, targets, 5)


def _cycles(rng, dy):
    """Many cycles to one peak (full or partial unloading): the ratchet when cyclic is on."""
    peak = float(rng.uniform(1.5, 80.0)) * dy
    depth = float(rng.choice([1.0, 0.5, 0.2]))
    targets = [peak]
    for _ in range(int(rng.integers(5, 25))):
        targets += [peak * (1.0 - depth) - (0.01 * peak if depth == 1.0 else 0.0), peak * 1.02]
    return _sample(rng, targets, 3)


def _elastic(rng, dy):
    """Below yield all the way: Hertz on every branch."""
    targets = [float(rng.uniform(-0.3, 1.0)) * dy for _ in range(int(rng.integers(3, 8)))]
    return _sample(rng, targets, 6)


def _repeated_peaks(rng, law: LawParams):
    """Repeated cycles to the envelope point itself, as a force-controlled test or a DEM contact
    meets it: each reload ends at the envelope point after its ratchet (found on a copy of the
    contact), jittered by up to 1e-12 or 1e-9 relative, then unloads to separation (or to half
    the peak). The cycle count must not depend on which side of the envelope point a peak lands.
    (A peak exactly on the envelope point is a corner of the force curve: which one-sided slope
    and branch label it gets is decided by the last bit of the ratchet shift, which the two
    implementations may round differently; 1e-12 is thousands of bits away.)"""
    dy = law.yield_approach
    jitter = float(rng.choice([1e-12, 1e-9]))
    contact = Contact(law, beyond_range=IGNORE)  # vectors go far beyond an illustration
    path: list[float] = []

    def leg(end: float) -> None:
        start = path[-1] if path else 0.0
        n = int(rng.integers(1, 4))
        for k in range(n):
            path.append(start + (end - start) * (k + 1) / n)
            contact.update(path[-1])

    leg(float(rng.uniform(2.0, 80.0)) * dy)
    for _ in range(int(rng.integers(5, 25))):
        s = contact.state
        peak = s.max_approach + s.ratchet_shift
        leg(peak * float(rng.choice([-0.01, 0.5])))
        # where this reload's creep (if any) ends: step a copy into the envelope band
        probe = copy.deepcopy(contact)
        probe.update(probe.state.ratchet_shift + probe.state.max_approach * (1.0 - 1e-6))
        t = probe.state
        envelope = t.max_approach + t.ratchet_shift + t.pending_ratchet
        leg(envelope * (1.0 + jitter * float(rng.uniform(-1.0, 1.0))))
    leg(-0.01 * path[-1])
    return path


def _by_yield_approach(family):
    return lambda rng, law: family(rng, law.yield_approach)


FAMILIES = {
    "random_walk": _by_yield_approach(_random_walk),
    "partial_reversals": _by_yield_approach(_partial_reversals),
    "deep_plastic": _by_yield_approach(_deep_plastic),
    "cycles": _by_yield_approach(_cycles),
    "elastic": _by_yield_approach(_elastic),
    "repeated_peaks": _repeated_peaks,
}


VARIANTS = ("cyclic_on", "cyclic_off", "transition", "deep", "shakedown", "table", "segments")
# the knots of the table variant (plastic depths): the histories reach below the first (the
# line towards x = 1) and far beyond the last (the line towards rho = 1)
TABLE_DEPTHS = (4.0, 10.0, 30.0, 100.0, 400.0)
# the loading segments of the segments variant: five power laws, the histories reach the last
SEGMENTS = {"depth": [1.0, 5.0, 20.0, 60.0, 150.0], "exponent": [1.3, 1.22, 1.1, 1.15, 0.95]}


def _variants(params: LawParams) -> dict[str, dict]:
    """The parameter document as given, and with the cyclic extension switched on and off."""
    base = params.to_dict()
    base["provenance"] = {k: v for k, v in base["provenance"].items()
                          if k != "geocontact_version"}
    on = copy.deepcopy(base)
    on["cyclic"]["enabled"] = True
    if on["cyclic"]["residual_ratio"]["coefficient"] <= on["cyclic"]["tolerance"]:
        on["cyclic"]["residual_ratio"] = {"coefficient": 0.3, "power": 1.0}
    on["cyclic"].pop("critical_cycle", None)
    off = copy.deepcopy(on)
    off["cyclic"]["enabled"] = False
    # the residual form with a transition depth (the FE calibrations use one)
    transition = copy.deepcopy(off)
    transition["residual_approach"]["transition_depth"] = 7.5
    # a third loading regime and a stretched residual form (the weak-sphere calibrations)
    deep = copy.deepcopy(transition)
    deep["loading"]["deep_plastic_approach_ratio"] = (
        3.0 * deep["loading"]["fully_plastic_approach_ratio"])
    deep["loading"]["deep_plastic_exponent"] = 1.0
    deep["residual_approach"]["log_power"] = 1.6
    deep["cyclic"]["enabled"] = True
    # the shakedown form of the cyclic extension: increments in every cycle, loops that close
    shakedown = copy.deepcopy(transition)
    shakedown["cyclic"].update(enabled=True, form="shakedown",
                               plastic_work_ratio={"coefficient": 0.3, "power": 1.5})
    # the tabulated residual form (on the deep variant: three regimes, cyclic on), its knots
    # on the deep variant's closed form, the middle ones moved off it so the two differ
    table = copy.deepcopy(deep)
    ratio = LawParams.from_dict(deep).residual_ratio(np.array(TABLE_DEPTHS))
    ratio = ratio * np.array([1.0, 1.05, 0.97, 1.02, 1.0])
    table["residual_approach"] = {"table": {"depth": list(TABLE_DEPTHS),
                                            "ratio": [float(r) for r in ratio]}}
    # the virgin curve as power-law segments (on the deep variant: cyclic on)
    segments = copy.deepcopy(deep)
    segments["loading"] = {"segments": copy.deepcopy(SEGMENTS)}
    out = {"cyclic_on": on, "cyclic_off": off, "transition": transition, "deep": deep,
           "shakedown": shakedown, "table": table, "segments": segments}
    assert tuple(out) == VARIANTS
    return out


def generate(params: LawParams, n_per_family: int = PER_FAMILY, seed: int = SEED) -> dict:
    rng = np.random.default_rng(seed)
    variants = _variants(params)
    cases = []
    for variant, doc in variants.items():
        law = LawParams.from_dict(doc)
        for family, make in FAMILIES.items():
            for k in range(n_per_family // len(variants)):
                approaches = make(rng, law)
                contact = Contact(law, beyond_range=IGNORE)
                forces, stiffnesses, branches = [], [], []
                for a in approaches:
                    f, s = contact.update(a)
                    forces.append(f)
                    stiffnesses.append(s)
                    branches.append(contact.state.branch)
                state = contact.state
                cases.append({
                    "name": f"{variant}/{family}/{k}",
                    "params": variant,
                    "approaches": approaches,
                    "forces": forces,
                    "stiffnesses": stiffnesses,
                    "branches": branches,
                    "final_state": {key: getattr(state, key) for key in STATE_KEYS},
                    "elastic_energy": contact.elastic_energy,
                    "dissipated_energy": contact.dissipated_energy,
                })
    return {
        "schema": GOLDEN_SCHEMA,
        "generator": ("python scripts/make_golden_vectors.py "
                      "(scalar reference geocontact.law.Contact)"),
        "seed": seed,
        "params": variants,
        "cases": cases,
    }


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python scripts/make_golden_vectors.py",
                            description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output JSON file")
    parser.add_argument("--params", default=str(DEFAULT_PARAMS),
                        help="geocontact.law/1 parameter file (default: %(default)s)")
    parser.add_argument("--per-family", type=int, default=PER_FAMILY,
                        help="histories per family, split over the parameter variants")
    parser.add_argument("--seed", type=int, default=SEED)

    def run() -> int:
        args = parser.parse_args(argv)
        check_output_file(args.out, "--out")
        variants = len(VARIANTS)
        if not variants <= args.per_family <= MAX_PER_FAMILY:
            raise InputError(f"--per-family: must be in [{variants}, {MAX_PER_FAMILY}] "
                             f"(split over {variants} parameter variants), got {args.per_family}")
        if args.seed < 0:
            raise InputError(f"--seed: must be an integer >= 0, got {args.seed}")
        golden = generate(load_params(args.params), args.per_family, args.seed)
        out = Path(args.out)
        # repr-exact floats (json writes the shortest round-tripping form)
        write_text_atomic(out, json.dumps(golden, separators=(",", ":")) + "\n")
        n_steps = sum(len(c["approaches"]) for c in golden["cases"])
        print(f"golden: {len(golden['cases'])} histories, {n_steps} steps -> {out}")
        return 0

    return run_reporting_errors(run)


if __name__ == "__main__":
    raise SystemExit(main())
