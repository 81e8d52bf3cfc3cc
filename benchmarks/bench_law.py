"""Kernel throughput: the hysteretic law against plain Hertz through the same structure, on 1
and 2 threads, beside the machine's memory bandwidth measured in the same run.

10^6 contacts, 100 steps of the calibrated parameter file. Every contact follows its own
sinusoidal approach history (random amplitude from 0.2 to 60 delta_y, random offset and phase),
so the population mixes contacts that are apart, elastic, on the virgin curve, unloading,
reloading and reversing. The histories are generated before timing; only the kernel calls are
timed (best of 3). Both laws run in the compiled core (geocontact.law._core, the C++ header);
the bytes a step moves per contact are counted from its layout (arrays.hpp).
"""

from __future__ import annotations

import os
import time

import numpy as np
from common import record

from geocontact.law import ContactArrays, LawParams, _core

REPEATS = 3


def histories(params: LawParams, n: int, steps: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    dy = params.yield_approach
    amplitude = dy * np.exp(rng.uniform(np.log(0.2), np.log(60.0), n))
    offset = amplitude * rng.uniform(-0.3, 0.6, n)
    phase = rng.uniform(0, 2 * np.pi, n)
    period = rng.uniform(20, 60, n)
    t = np.arange(steps)[:, None]
    return offset + amplitude * np.sin(2 * np.pi * t / period + phase)


def time_kernel(contacts: ContactArrays, path: np.ndarray, threads: int) -> tuple[float, float]:
    """(wall, CPU) seconds of the fastest of REPEATS runs of the whole path from untouched
    contacts. CPU time counts every thread; on a shared machine wall > CPU / threads says how
    much of the run the threads spent waiting for a core."""
    contacts.threads = threads
    best = (np.inf, np.inf)
    for _ in range(REPEATS):
        contacts.reset()
        start, cpu = time.perf_counter(), time.process_time()
        for row in path:
            contacts.step_unchecked(row)
        best = min(best, (time.perf_counter() - start, time.process_time() - cpu))
    return best


def memory_bandwidth(n: int = 20_000_000) -> dict:
    """STREAM-like copy (b = a) and add (a = b + c) with numpy on one thread, in GB/s counting
    the bytes read and written (16 and 24 per element, as STREAM does), best of 5."""
    a, b, c = np.ones(n), np.full(n, 2.0), np.full(n, 3.0)
    out = {}
    for name, run, nbytes in (("copy", lambda: np.copyto(b, a), 16 * n),
                              ("add", lambda: np.add(b, c, out=a), 24 * n)):
        best = np.inf
        for _ in range(5):
            start = time.perf_counter()
            run()
            best = min(best, time.perf_counter() - start)
        out[name] = nbytes / best / 1e9
    return out


def main(params: LawParams, n: int = 1_000_000, steps: int = 100) -> list[dict]:
    path = np.ascontiguousarray(histories(params, n, steps))
    law = ContactArrays(params, n)
    hertz = ContactArrays.hertz(params.material, n)
    bandwidth = memory_bandwidth()
    load_before = os.getloadavg()[0]
    timings = {(name, threads): time_kernel(c, path, threads)
               for threads in (1, 2) for name, c in (("law", law), ("hertz", hertz))}
    seconds = {key: wall for key, (wall, _) in timings.items()}
    cpu_seconds = {key: cpu for key, (_, cpu) in timings.items()}
    # the two thread counts must agree bit for bit (the tests check it too)
    final = {}
    for threads in (1, 2):
        law.threads = threads
        law.reset()
        for row in path:
            law.step_unchecked(row)
        final[threads] = [a.copy() for a in law.state.as_dict().values()]
    identical = all(np.array_equal(x, y) for x, y in zip(final[1], final[2], strict=True))
    bandwidth_after = memory_bandwidth()
    updates = n * steps
    branches = np.bincount(law.branch, minlength=5) / n
    rate = {key: updates / t for key, t in seconds.items()}
    common = dict(
        contacts=n, steps=steps,
        bytes_per_update_law=_core.STEP_BYTES, bytes_per_update_hertz=_core.HERTZ_STEP_BYTES,
        bytes_note=("counted from the layout: state record (12 doubles + int8 branch, "
                    f"{_core.STATE_BYTES} B, its force the output force) read and written, "
                    "approach read, stiffness written"),
        memory_bandwidth_GBps={"before": bandwidth, "after": bandwidth_after},
        load_average_1min={"before": load_before, "after": os.getloadavg()[0]},
        cores=os.cpu_count(),
        thread_results_bitwise_identical=identical,
        final_branch_fractions=dict(zip(
            ["apart", "virgin", "unloading", "reloading", "ratchet"], branches.tolist(),
            strict=True)),
        goal="law >= 5e7 updates/s on one thread, >= 1.8x that on two",
    )
    records = []
    for threads in (1, 2):
        law_rate, hertz_rate = rate[("law", threads)], rate[("hertz", threads)]
        traffic = law_rate * _core.STEP_BYTES / 1e9
        name = "law_kernel_throughput" + ("" if threads == 1 else "_2threads")
        records.append(record(
            name, law_rate, "contact updates/s",
            f"plain Hertz, same structure, {threads} thread(s)", hertz_rate,
            ratio=seconds[("law", threads)] / seconds[("hertz", threads)],
            threads=threads, seconds_law=seconds[("law", threads)],
            seconds_hertz=seconds[("hertz", threads)],
            cpu_seconds_law=cpu_seconds[("law", threads)],
            law_updates_per_cpu_second=updates / cpu_seconds[("law", threads)],
            law_traffic_GBps=traffic,
            speedup_over_1_thread=law_rate / rate[("law", 1)],
            hertz_speedup_over_1_thread=hertz_rate / rate[("hertz", 1)],
            **common,
            note=(f"{threads} thread(s); params-reference.json, mixed population; "
                  f"{_core.STEP_BYTES} B/update = {traffic:.2g} GB/s against a measured "
                  f"copy {bandwidth['copy']:.3g} GB/s, add {bandwidth['add']:.3g} GB/s; "
                  f"{updates / cpu_seconds[('law', threads)]:.3g} updates per CPU-second; "
                  f"load average {load_before:.1f} on {os.cpu_count()} cores"
                  + ("" if threads == 1 else
                     f"; speedup {law_rate / rate[('law', 1)]:.2f}x (Hertz "
                     f"{hertz_rate / rate[('hertz', 1)]:.2f}x), bitwise identical: "
                     f"{identical}")),
        ))
    return records
