"""Kernel throughput: the hysteretic law against plain Hertz through the same kernel structure.

10^6 contacts, 100 steps. Every contact follows its own sinusoidal approach history (random
amplitude from 0.2 to 60 delta_y, random offset and phase), so the population mixes contacts that
are apart, elastic, on the virgin curve, unloading, reloading and reversing. The histories are
generated before timing; only the kernel calls are timed. One thread (numba, no parallel loop).
"""

from __future__ import annotations

import time

import numpy as np
from common import record

from geocontact.law import ContactArrays, LawParams


def histories(params: LawParams, n: int, steps: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    dy = params.yield_approach
    amplitude = dy * np.exp(rng.uniform(np.log(0.2), np.log(60.0), n))
    offset = amplitude * rng.uniform(-0.3, 0.6, n)
    phase = rng.uniform(0, 2 * np.pi, n)
    period = rng.uniform(20, 60, n)
    t = np.arange(steps)[:, None]
    return offset + amplitude * np.sin(2 * np.pi * t / period + phase)


def time_kernel(contacts: ContactArrays, path: np.ndarray, repeats: int = 3) -> float:
    best = np.inf
    for _ in range(repeats):
        contacts.__init__(contacts.params, contacts.n, _packed=contacts._p)
        start = time.perf_counter()
        for row in path:
            contacts.step_unchecked(row)
        best = min(best, time.perf_counter() - start)
    return best


def main(params: LawParams, n: int = 1_000_000, steps: int = 100) -> dict:
    path = np.ascontiguousarray(histories(params, n, steps))
    law = ContactArrays(params, n)
    hertz = ContactArrays.hertz(params.material, n)
    for c in (law, hertz):  # compile
        c.step_unchecked(path[0])
    t_law = time_kernel(law, path)
    t_hertz = time_kernel(hertz, path)
    updates = n * steps
    law_rate, hertz_rate = updates / t_law, updates / t_hertz
    branches = np.bincount(law.branch, minlength=5) / n
    return record(
        "law_kernel_throughput", law_rate, "contact updates/s",
        "plain Hertz, same kernel structure", hertz_rate,
        ratio=t_law / t_hertz,
        contacts=n, steps=steps, seconds_law=t_law, seconds_hertz=t_hertz,
        goal="law >= 5e7 updates/s on one core and cost <= 1.5x Hertz",
        final_branch_fractions=dict(zip(
            ["apart", "virgin", "unloading", "reloading", "ratchet"], branches.tolist(),
            strict=True)),
        note="1 thread; mixed elastic/plastic/reversing population",
    )
