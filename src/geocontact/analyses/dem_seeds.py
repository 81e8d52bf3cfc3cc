"""``geocontact dem oedometer --seeds N``: the same oedometer on N samples (seeds ``seed``,
``seed + 1``, ...), each a ``run_dem`` result folder, and the mean and spread of every cycle's
measures over the samples per contact law (docs/sample-study.md, "The oedometer").

One sample is one realisation of a random packing: its moduli and loop areas scatter from seed to
seed by as much as two laws may differ, so a comparison of laws reads the mean against the
spread. The folder is written as one unit: an interrupted study leaves nothing that looks done.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..files import atomic_directory, check_replaceable, provenance, write_csv, write_json_atomic
from .dem import Settings, check_run, run_dem

SCHEMA = "geocontact.dem-seeds/1"
MAX_SEEDS = 20  # as the cyclic-shear study's (dem_cyclic.MAX_SEEDS)
# The per-cycle measures averaged over the samples (run_dem's cycles, docs/dem.md
# "Compressibility"), and the law's share of the walls' work.
MEASURES = ("peak_stress_Pa", "valley_stress_Pa", "residual_strain", "start_void_ratio",
            "peak_void_ratio", "valley_void_ratio", "reload_modulus_Pa", "unload_modulus_Pa",
            "unload_modulus_initial_Pa", "compression_index", "swelling_index", "loop_area_J_m3",
            "loop_area_top_wall_J_m3", "wall_work_J", "law_dissipated_J", "law_share",
            "contacts_per_grain")


def seed_folder(seed: int) -> str:
    return f"seed-{seed}"


def check_seeds(settings: Settings, seeds: int) -> None:
    if not 1 <= seeds <= MAX_SEEDS:
        raise InputError(f"seeds: must be in [1, {MAX_SEEDS}], got {seeds}")
    if settings.seed + seeds > 2**31 - 2:
        raise InputError(f"seed: must be at most {2**31 - 2 - seeds}, got {settings.seed}")


def measures(cycle: dict) -> dict:
    """A run's cycle with the law's share of the walls' work added (``MEASURES``' last
    derived one)."""
    work = cycle["wall_work_J"]
    share = cycle["law_dissipated_J"] / work if work and work > 0 else None
    return {**cycle, "law_share": share}


def statistics(values: list[float | None]) -> dict:
    """Mean, sample standard deviation, least and largest of the samples that have a value (a
    modulus or index a cycle's branch did not define is None and left out; ``count`` says how
    many were used)."""
    x = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if x.size == 0:
        return {"count": 0, "mean": None, "std": None, "min": None, "max": None}
    return {"count": int(x.size), "mean": float(x.mean()),
            "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
            "min": float(x.min()), "max": float(x.max())}


# The measures compared law against baseline sample by sample (the same seed: the same random
# sample, consolidated with each law), as ratios.
PAIRED = ("reload_modulus_Pa", "unload_modulus_Pa", "unload_modulus_initial_Pa",
          "compression_index", "swelling_index", "loop_area_J_m3", "loop_area_top_wall_J_m3",
          "wall_work_J")


def paired(documents: dict[int, dict], law: str, baseline: str) -> list[dict]:
    """Per cycle, each ``PAIRED`` measure of ``law`` over ``baseline`` on the same sample (seed),
    with its statistics over the samples: a like-for-like comparison whose spread is the
    seeds' effect on the ratio, smaller than the spread of either law's values."""
    cycles = []
    for k, first in enumerate(next(iter(documents.values()))["runs"][law]["cycles"]):
        row = {"cycle": first["cycle"]}
        for m in PAIRED:
            ratios = []
            for doc in documents.values():
                a, b = doc["runs"][law]["cycles"][k][m], doc["runs"][baseline]["cycles"][k][m]
                ratios.append(a / b if a is not None and b not in (None, 0.0) else None)
            row[m] = statistics(ratios)
        cycles.append(row)
    return cycles


def summarise(documents: dict[int, dict], contacts: tuple[str, ...]) -> dict:
    """Per contact law: per cycle, every measure's statistics over the samples, and the
    calibrated range's worst sample."""
    laws = {}
    for contact in contacts:
        runs = {seed: doc["runs"][contact] for seed, doc in documents.items()}
        counts = {len(r["cycles"]) for r in runs.values()}
        if len(counts) != 1:
            raise InputError(f"seeds: the samples ran different numbers of cycles {counts}")
        cycles = []
        for k in range(counts.pop()):
            rows = {seed: measures(r["cycles"][k])
                    for seed, r in runs.items()}
            first = next(iter(rows.values()))
            cycles.append({"cycle": first["cycle"], "history": first["history"],
                           **{m: statistics([row[m] for row in rows.values()])
                              for m in MEASURES}})
        ranges = [r["calibrated_range"] for r in runs.values() if r["calibrated_range"]]
        laws[contact] = {
            "samples": {str(seed): {"packing_fraction": r["packing_fraction"],
                                    "void_ratio_at_stress": r["void_ratio_at_stress"],
                                    "contacts_per_grain_at_stress":
                                        r["contacts_per_grain_at_stress"],
                                    "runtime_s": r["runtime_s"]}
                        for seed, r in runs.items()},
            "void_ratio_at_stress": statistics([r["void_ratio_at_stress"]
                                                for r in runs.values()]),
            "cycles": cycles,
            "calibrated_range": None if not ranges else {
                "calibrated_max_depth": ranges[0]["calibrated_max_depth"],
                "beyond_range_contacts_max": max(r["beyond_range_contacts"] for r in ranges),
                "beyond_range_max_depth": max(r["beyond_range_max_depth"] for r in ranges),
                "walls_beyond_range_contacts_max": max(r["walls_beyond_range_contacts"]
                                                       for r in ranges)},
        }
    return laws


def cycles_table(documents: dict[int, dict], contacts: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Every sample's cycles in one table (contact, seed, cycle, the measures)."""
    rows = [(contact, seed, measures(c)) for contact in contacts
            for seed, doc in documents.items() for c in doc["runs"][contact]["cycles"]]
    table = {"contact": np.array([r[0] for r in rows]),
             "seed": np.array([r[1] for r in rows]),
             "cycle": np.array([r[2]["cycle"] for r in rows])}
    for m in MEASURES:
        values = [r[2][m] for r in rows]
        table[m] = np.array([math.nan if v is None else v for v in values], dtype=float)
    return table


def run_dem_seeds(test: str, law: str | Path, settings: Settings, *, seeds: int,
                  contacts: tuple[str, ...], ranks: int, out: str | Path,
                  overwrite: bool = False,
                  progress: Callable[[str], None] | None = None) -> dict:
    """Run ``test`` on ``seeds`` samples into ``out``: ``seed-K/`` (``run_dem``'s folder for seed
    K), ``cycles.csv`` (every sample's cycles) and ``summary.json`` (``SCHEMA``: per contact law
    and cycle, each measure's mean, spread, least and largest over the samples)."""
    check_seeds(settings, seeds)
    law_path, _ = check_run(settings, law, contacts, ranks)
    check_replaceable(out, "dem", overwrite=overwrite)
    inputs = {"test": test, "law": str(law_path), "contacts": list(contacts), "ranks": ranks,
              "seeds": seeds, **asdict(settings)}
    documents = {}
    with atomic_directory(out, "dem", overwrite=overwrite, inputs=inputs) as tmp:
        for k in range(seeds):
            seed = settings.seed + k
            if progress:
                progress(f"sample {k + 1} of {seeds} (seed {seed})")
            documents[seed] = run_dem(test, law_path, replace(settings, seed=seed),
                                      contacts=contacts, ranks=ranks,
                                      out=tmp / seed_folder(seed), progress=progress)
        document = {"schema": SCHEMA, "test": test, "ranks": ranks, "law": str(law_path),
                    "law_label": documents[settings.seed]["law_label"],
                    "seeds": [settings.seed + k for k in range(seeds)],
                    "laws": summarise(documents, contacts),
                    "paired": {f"geocontact/{b}": paired(documents, "geocontact", b)
                               for b in contacts if b != "geocontact" and
                               "geocontact" in contacts},
                    "provenance": provenance("dem", inputs)}
        write_csv(tmp / "cycles.csv", cycles_table(documents, contacts))
        write_json_atomic(tmp / "summary.json", document)
    return document
