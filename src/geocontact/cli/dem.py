"""``geocontact dem``: a DEM sample in LAMMPS (examples/lammps/in.TEST) -> cycles, contacts;
``geocontact dem seismic RECORD``: the sample under a seismic record -> settlement, dissipation."""

from __future__ import annotations

import sys

from ..errors import InputError
from ..files import Output, claim
from .common import add_force_flag, print_json


def register(sub) -> None:
    from ..analyses.dem import CONTACTS, TESTS

    p = sub.add_parser(
        "dem",
        help="a DEM sample in LAMMPS (oedometer: stress-strain loops, residual strain and "
             "dissipation per cycle, coordination, per-contact residual approach; seismic "
             "RECORD: settlement and dissipation under a record)",
        description=(
            "Run examples/lammps/in.TEST (from the checkout, after `make plugin`) with the law "
            "file on --ranks MPI ranks, for the geocontact law and/or LAMMPS's granular "
            "hertz/material + Mindlin, and write the time series, the per-cycle numbers and the "
            "per-contact residual approach as CSVs with a summary.json; `seismic RECORD`: the "
            "sample sheared by its base along the record's ground displacement under constant "
            "vertical stress, settlement and dissipation against time (docs/dem.md)."
        ),
    )
    p.add_argument("test", choices=[*TESTS, "seismic", "cyclic-shear"], metavar="TEST",
                   help="the test: oedometer, seismic or cyclic-shear")
    p.add_argument("record", nargs="?", default=None,
                   help="seismic: the record, an AT2/CSV file, a FEMA P695 component "
                        "(KOBE/NIS000) or ELCENTRO1940/ELC180")
    p.add_argument("--law", required=False, help="law parameters (geocontact.law/1 JSON)")
    p.add_argument("--grains", type=int, default=None,
                   help="number of grains (default 2000; seismic 1000)")
    p.add_argument("--ranks", type=int, default=1, help="MPI ranks (default 1)")
    p.add_argument("--contact", default="geocontact", choices=[*CONTACTS, "both", "all"],
                   help="contact model: geocontact (the law file), elastic (its grain's elastic "
                        "law through the same pair style and walls), granular (pair granular "
                        "hertz/material + fix wall/gran, a cross-check), both (geocontact and "
                        "elastic: like for like) or all (default geocontact)")
    p.add_argument("--walls", default=None, choices=CONTACTS,
                   help="the walls' law alone: geocontact (fix wall/geocontact) or granular "
                        "(fix wall/gran); default: that of --contact")
    p.add_argument("--restitution", type=float, default=None,
                   help="the normal damping as the coefficient of restitution of an elastic "
                        "impact, in [0.01, 1], for every contact model (default: that of "
                        "damping 0.5 of critical, 0.273)")
    p.add_argument("--stress", type=float, nargs="+", default=None, metavar="PA",
                   help="vertical stress before the cycles, Pa (default 5000); cyclic-shear: "
                        "the mean stresses of consolidation, one study each (default 1e5)")
    p.add_argument("--radius", type=float, default=None,
                   help="median grain radius, m (default 1e-3)")
    p.add_argument("--spread", type=float, default=None,
                   help="standard deviation of ln(radius) (default 0.3)")
    p.add_argument("--inertia", type=float, default=None,
                   help="inertia number of the cycles (default 1e-3); seismic: the largest of "
                        "the shaking, which sets the time compression (default 1e-3)")
    p.add_argument("--strain", type=float, default=None,
                   help="seismic: peak base displacement over the sample height (default 2e-3)")
    p.add_argument("--decimate", type=int, default=None,
                   help="seismic: use every k-th record sample (default 1)")
    p.add_argument("--baseline", default=None,
                   help="seismic: baseline correction of the acceleration, none, mean, linear "
                        "or quadratic (default linear); cyclic-shear: the contact beside the "
                        "law, elastic (the grain's elastic law through the same pair style; "
                        "default), granular (pair granular hertz/material + Mindlin) or none")
    p.add_argument("--amplitudes", type=float, nargs="+", default=None, metavar="A",
                   help="cyclic-shear: shear strain amplitudes, increasing (default 9 from "
                        "1e-6 to 1e-2, log-spaced)")
    p.add_argument("--cycles", type=int, default=None,
                   help="cyclic-shear: cycles per amplitude, the last measured (default 3)")
    p.add_argument("--seeds", type=int, default=None,
                   help="cyclic-shear: samples per law and stress, seeds --seed, --seed + 1, "
                        "... (default 3); oedometer: run that many samples into --out/seed-K "
                        "and give every cycle's mean and spread over them (default: one "
                        "sample, no seed folders)")
    p.add_argument("--friction", type=float, default=None,
                   help="cyclic-shear: Coulomb friction coefficient of the contacts "
                        "(default 0.5)")
    p.add_argument("--damping", type=float, default=None,
                   help="cyclic-shear: contact damping, fraction of critical (default 0.5)")
    p.add_argument("--cyclic-extension", default=None, choices=["file", "off"],
                   help="cyclic-shear: the law's cyclic (ratchet) extension as the file has it "
                        "(default) or off (it counts micro-cycles of any amplitude: "
                        "docs/sample-study.md)")
    p.add_argument("--drained", action="store_true",
                   help="cyclic-shear: after each cycle a servo on the box height restores the "
                        "vertical stress (volumetric strain per cycle); default: constant volume "
                        "throughout")
    p.add_argument("--targets", type=float, nargs="+", default=None, metavar="RATIO",
                   help="peak and valley stresses of the cycles as multiples of --stress "
                        "(default: 3 repeated, 3 increasing, 3 decreasing cycles)")
    p.add_argument("--preset", default=None, choices=["high-stress"],
                   help="oedometer: high-stress: --stress 5e5 and --targets 2 0.5 2 0.5 4 1 4 1 "
                        "(virgin loading to 1 and 2 MPa, each with an unload-reload loop to a "
                        "quarter; the contacts of mm grains yield well), unless given")
    p.add_argument("--memory", default=None, choices=["pair", "place"],
                   help="oedometer, seismic: the memory of pair_style geocontact and the "
                        "geocontact walls: pair (default, the dent follows the contact record) "
                        "or place (forgotten once the contact point has travelled past it, "
                        "without creating energy; docs/dem.md 'Memory with a place')")
    p.add_argument("--seed", type=int, default=None, help="random seed of the sample")
    p.add_argument("--out", help="output directory (written as one unit)")
    add_force_flag(p)
    p.add_argument("--json", action="store_true", help="print the summary as one JSON document")
    p.set_defaults(run=run)


# The flags that only some tests take (the others are common to all three).
TESTS_TAKING = {
    "preset": ("oedometer",), "walls": ("oedometer",), "targets": ("oedometer",),
    "strain": ("seismic",), "decimate": ("seismic",),
    "baseline": ("seismic", "cyclic-shear"),
    "restitution": ("oedometer", "seismic"), "memory": ("oedometer", "seismic"),
    "seeds": ("cyclic-shear", "oedometer"),
    **dict.fromkeys(("amplitudes", "cycles", "friction", "damping", "drained",
                     "cyclic_extension"),
                    ("cyclic-shear",)),
}


def refuse_other_tests_flags(args) -> None:
    """One line naming the first flag given that ``args.test`` does not take (TESTS_TAKING),
    and the record given to a test other than seismic."""
    for name, tests in TESTS_TAKING.items():
        if args.test not in tests and getattr(args, name) not in (None, False):
            raise InputError(f"--{name.replace('_', '-')}: only for the {' and '.join(tests)} "
                             f"test{'s' if len(tests) > 1 else ''}, not for {args.test}")
    if args.record is not None and args.test != "seismic":
        raise InputError(f"record: only the seismic test takes a record, got {args.record!r}")


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run(args) -> int:
    from ..analyses.dem import PRESETS, Settings, run_dem

    if args.law is None:
        raise InputError("--law: missing (law parameters, geocontact.law/1 JSON)")
    if args.out is None:
        raise InputError("--out: missing (output directory)")
    refuse_other_tests_flags(args)
    if args.test == "seismic":
        return run_seismic(args)
    if args.test == "cyclic-shear":
        return run_cyclic(args)
    args.stress = _one_stress(args.stress)
    if args.preset is not None:
        stress, targets = PRESETS[args.preset]
        args.stress = stress if args.stress is None else args.stress
        args.targets = list(targets) if args.targets is None else args.targets
    settings = Settings(grains=2000 if args.grains is None else args.grains)
    for name in ("stress", "radius", "spread", "inertia", "seed", "walls", "restitution"):
        if getattr(args, name) is not None:
            setattr(settings, name, getattr(args, name))
    if args.targets is not None:
        settings.targets = tuple(args.targets)
    if args.memory is not None:
        settings.extra["memory"] = args.memory
    contacts = contact_choice(args.contact)
    common = {"contacts": contacts, "ranks": args.ranks, "out": args.out,
              "overwrite": args.force, "progress": _progress}
    with claim([Output(args.out, "folder", "--out")], "dem", overwrite=args.force):
        if args.seeds is None:
            document = run_dem(args.test, args.law, settings, **common)
        else:
            from ..analyses.dem_seeds import run_dem_seeds

            document = run_dem_seeds(args.test, args.law, settings, seeds=args.seeds, **common)
    if args.json:
        print_json(document)
    elif args.seeds is None:
        print_runs(document)
        print(f"wrote {args.out}")
    else:
        print_seeds(document)
        print(f"wrote {args.out}")
    return 0


def print_runs(document: dict) -> None:
    """One oedometer: per contact model its sample and every cycle's measures."""
    for contact, s in document["runs"].items():
        print(f"{contact}: {s['grains']} grains, {s['steps']} steps in {s['runtime_s']:.1f} s "
              f"(dt {s['timestep_s']:.3g} s), packing fraction {s['packing_fraction']:.3f}, "
              f"{s['contacts_per_grain_at_stress']:.2f} contacts/grain at "
              f"{s['reference_stress_Pa']:.4g} Pa, inertia number "
              f"{s['inertia_number']['at_lowest_target']:.2g}")
        for c in s["cycles"]:
            print(f"  cycle {c['cycle']} {c['history']:10s} {c['valley_stress_Pa']:9.4g}-"
                  f"{c['peak_stress_Pa']:9.4g} Pa: residual strain {c['residual_strain']:+.3e}, "
                  f"wall work {c['wall_work_J']:.3e} J, law dissipation "
                  f"{c['law_dissipated_J']:.3e} J")
            print(f"    e {c['peak_void_ratio']:.4f} at the peak, {c['valley_void_ratio']:.4f} "
                  f"at the valley; M reload {_mpa(c['reload_modulus_Pa'])}, unload "
                  f"{_mpa(c['unload_modulus_Pa'])} (initial "
                  f"{_mpa(c['unload_modulus_initial_Pa'])}); Cc {_num(c['compression_index'])}, "
                  f"Cs {_num(c['swelling_index'])}; loop area {c['loop_area_J_m3']:.4g} J/m3")
        if s["calibrated_range"] is not None:
            r = s["calibrated_range"]
            print(f"  calibrated range: {r['beyond_range_contacts']} contacts beyond the file's "
                  f"depth {_num(r['calibrated_max_depth'])} at the end (deepest "
                  f"{r['beyond_range_max_depth']:.4g} delta_y); walls "
                  f"{r['walls_beyond_range_contacts']}")


def print_seeds(document: dict) -> None:
    """``--seeds N``: every cycle's mean and spread over the samples, and the law over its
    baseline on the same sample."""
    print(f"{len(document['seeds'])} samples (seeds {document['seeds'][0]}-"
          f"{document['seeds'][-1]}), mean +- standard deviation over them:")
    for contact, law in document["laws"].items():
        e0 = law["void_ratio_at_stress"]
        print(f"{contact}: e {_pm(e0)} at the reference stress")
        for c in law["cycles"]:
            print(f"  cycle {c['cycle']} to {_pm(c['peak_stress_Pa'], 1e6)} MPa: e peak "
                  f"{_pm(c['peak_void_ratio'])}, M reload {_pm(c['reload_modulus_Pa'], 1e6)} MPa,"
                  f" unload {_pm(c['unload_modulus_Pa'], 1e6)} MPa; Cc "
                  f"{_pm(c['compression_index'])}, Cs {_pm(c['swelling_index'])}; loop "
                  f"{_pm(c['loop_area_top_wall_J_m3'])} J/m3 (top wall); law "
                  f"{_pm(c['law_share'])} of the walls' work")
        r = law["calibrated_range"]
        if r is not None:
            print(f"  calibrated range: at most {r['beyond_range_contacts_max']} contacts beyond "
                  f"the file's depth {_num(r['calibrated_max_depth'])} in a sample (deepest "
                  f"{r['beyond_range_max_depth']:.4g} delta_y)")
    for pair, cycles in document["paired"].items():
        print(f"{pair} on the same sample, mean +- standard deviation of the ratio:")
        for c in cycles:
            print(f"  cycle {c['cycle']}: M reload {_pm(c['reload_modulus_Pa'])}, unload "
                  f"{_pm(c['unload_modulus_Pa'])}; Cc {_pm(c['compression_index'])}, Cs "
                  f"{_pm(c['swelling_index'])}; loop {_pm(c['loop_area_top_wall_J_m3'])} "
                  "(top wall)")


def _pm(stats: dict, unit: float = 1.0) -> str:
    if stats["mean"] is None:
        return "-"
    return f"{stats['mean'] / unit:.4g} +- {stats['std'] / unit:.2g}"


def _num(value) -> str:
    return "-" if value is None else f"{value:.4g}"


def _mpa(value) -> str:
    return "-" if value is None else f"{value / 1e6:.4g} MPa"


def contact_choice(choice: str) -> tuple[str, ...]:
    """The contact models of ``--contact``: one, ``both`` (like for like) or ``all``."""
    from ..analyses.dem import CONTACTS, LIKE_FOR_LIKE

    return {"both": LIKE_FOR_LIKE, "all": CONTACTS}.get(choice, (choice,))


def run_seismic(args) -> int:
    from ..analyses.dem_seismic import SeismicSettings
    from ..analyses.dem_seismic import run_seismic as run

    if args.record is None:
        raise InputError("record: missing (an AT2/CSV file, a FEMA P695 component such as "
                         "KOBE/NIS000, or ELCENTRO1940/ELC180)")
    args.stress = _one_stress(args.stress)
    if args.baseline is not None and args.baseline not in ("none", "mean", "linear",
                                                           "quadratic"):
        raise InputError(f"--baseline: seismic: must be none, mean, linear or quadratic, got "
                         f"{args.baseline!r}")
    settings = SeismicSettings()
    for name in ("grains", "stress", "radius", "spread", "inertia", "seed", "strain",
                 "decimate", "baseline", "restitution"):
        if getattr(args, name) is not None:
            setattr(settings, name, getattr(args, name))
    if args.memory is not None:
        settings.extra["memory"] = args.memory
    contacts = contact_choice(args.contact)
    with claim([Output(args.out, "folder", "--out")], "dem", overwrite=args.force):
        document = run(args.record, args.law, settings, contacts=contacts, ranks=args.ranks,
                       out=args.out, overwrite=args.force, progress=_progress)
    if args.json:
        print_json(document)
        return 0
    rec = document["record"]
    print(f"record {rec['name']}: {rec['duration_s']:.4g} s, PGA at {rec['peak_time_s']:.4g} s "
          f"({rec['peak_time_fraction']:.3f} of the record): paper rule {rec['paper_rule']}")
    for contact, s in document["runs"].items():
        print(f"{contact}: {s['grains']} grains, {s['steps']} steps in {s['runtime_s']:.1f} s "
              f"(time compressed {s['timescale']:.4g}x, inertia number max "
              f"{s['inertia_number']['max']:.2g}, rms {s['inertia_number']['rms']:.2g}, "
              f"loading/resonance {s['loading_over_resonance']:.2g}); "
              f"settlement {s['settlement_m']:.4g} m (vertical strain "
              f"{s['vertical_strain']:.3e}), wall work {s['wall_work_J']:.4g} J, law "
              f"dissipation {s['law_dissipated_J']:.4g} J")
    print(f"wrote {args.out}")
    return 0


def _one_stress(stress: list[float] | None) -> float | None:
    if stress is not None and len(stress) != 1:
        raise InputError(f"--stress: one stress for this test, got {len(stress)}")
    return None if stress is None else stress[0]


def run_cyclic(args) -> int:
    from ..analyses.dem_cyclic import COMMAND, CyclicSettings, run_cyclic_shear

    if args.contact != "geocontact":
        raise InputError("--contact: not for the cyclic-shear test (it runs the law and "
                         "--baseline)")
    settings = CyclicSettings(drained=args.drained)
    for name in ("grains", "radius", "spread", "inertia", "seed", "cycles", "seeds",
                 "friction", "damping", "baseline", "cyclic_extension"):
        if getattr(args, name) is not None:
            setattr(settings, name, getattr(args, name))
    if args.stress is not None:
        settings.stresses = tuple(args.stress)
    if args.amplitudes is not None:
        settings.amplitudes = tuple(args.amplitudes)
    with claim([Output(args.out, "folder", "--out")], COMMAND, overwrite=args.force):
        document = run_cyclic_shear(args.law, settings, out=args.out, ranks=args.ranks,
                                    overwrite=args.force, progress=_progress)
    if args.json:
        print_json(document)
        return 0
    for r in document["runs"]:
        print(f"{r['run']}: {r['grains']} grains, packing fraction {r['packing_fraction']:.3f}, "
              f"{r['contacts_per_grain']:.2f} contacts/grain at "
              f"{r['consolidated_mean_stress_Pa']:.4g} Pa, Gmax {r['Gmax_Pa']:.4g} Pa")
    for c in document["curves"]:
        print(f"  {c['law']:10s} p {c['consolidation_stress_Pa']:.3g} Pa seed {c['seed']} "
              f"gamma {c['amplitude']:.3g}: G/Gmax {c['G_over_Gmax']:.3f} D "
              f"{c['damping_ratio']:.4f}, "
              f"{c['mean_stress_change_per_cycle_Pa']:+.3g} Pa mean stress/cycle, I "
              f"{c['inertia_number']:.2g}")
    print(f"wrote {args.out}")
    return 0
