"""The paper's loading-history study on our FE engine, and its findings checked against it.

The runs (repeated, monotonically decreasing and increasing histories for sigma_c = 10 and
1 MPa, and the repeated history for a von Mises grain of the same strength) and the numbers the
paper quotes live in ``data/paper-histories.toml``. ``run_paper_histories`` runs them as one FE
campaign (cached, resumable) and analyses each with ``calibrate.cyclic_fit``; ``paper_findings``
turns the analyses into the table of docs/cycles.md: each of the paper's statements, the
quantity that tests it, our value and whether it agrees. A statement our runs cannot test says
so (``agrees`` is None, ``our_value`` names what is missing).
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..calibrate.cyclic_fit import (
    DEFAULT_TOLERANCE,
    ELASTIC_SHAKEDOWN,
    RATCHETTING,
    RESOLUTION,
    CycleAnalysis,
    analyse,
    ratchetting_cycles,
)
from ..errors import InputError
from ..files import write_csv, write_json_atomic
from ..grain.force_history import preset_history
from ..grain.material import Material, preset
from .cycles import fe_cycle_windows, reloading_stiffness

# Tolerances at which the critical cycles are also reported (the paper does not state its own).
EXTRA_TOLERANCES = (1e-3, 1e-4)
# "Hysteresis decreases quickly after the first cycle": every later cycle this much weaker.
WEAKER = 0.1


def study() -> dict[str, Any]:
    """The run definitions and the paper's quoted numbers (data/paper-histories.toml)."""
    text = (resources.files("geocontact") / "data" / "paper-histories.toml").read_text()
    return tomllib.loads(text)


@dataclass
class PaperRun:
    name: str
    material_name: str
    material: Material
    history: str
    forces: list[float]
    curve: dict[str, np.ndarray]
    summary: dict[str, Any]
    analysis: CycleAnalysis
    extra: dict[float, CycleAnalysis]  # the same cycles analysed at EXTRA_TOLERANCES
    # monotonically increasing histories: a single load 0 -> F_k -> 0 per peak, same mesh
    single_loads: list[dict[str, Any]] = field(default_factory=list)

    @property
    def windows(self) -> list[tuple[int, int]]:
        return fe_cycle_windows(self.curve, self.summary["cycles"])

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "material_preset": self.material_name,
            "material": self.material.to_dict(),
            "history": self.history,
            "forces_N": self.forces,
            "fe": {k: self.summary.get(k) for k in (
                "first_yield_force_N", "fully_plastic_force_N", "mesh", "steps", "wall_time_s",
                "version", "inputs")},
            "analysis": self.analysis.to_dict(),
            "critical_cycles_at_other_tolerances": {
                f"{t:g}": a.critical_cycles for t, a in self.extra.items()},
            "single_loads": self.single_loads,
        }


def study_jobs(mesh: str = "default", *, steps_per_segment: int | None = None,
               only: list[str] | None = None, mesh_checks: dict[str, str] | None = None,
               fe_model: dict[str, Any] | None = None,
               fe_model_materials: Sequence[str] | None = None,
               others_fe_model: dict[str, Any] | None = None):
    """The study's FE jobs: ``(plan, jobs)``, plan = [(label, run name, mesh)] in job order.
    ``fe_model``: kinematics, mesh_rule, step_rule and max_step_ratio of the runs (``FemJob``;
    the FE defaults when None); ``fe_model_materials``: the material presets it applies to (None:
    every run), the others run with the FE defaults, e.g. finite strain only for the weak grain,
    where small strain is not valid (docs/verification.md, item 13), changed by
    ``others_fe_model`` (FemJob keywords, e.g. ``{"mesh_rule": "yield"}``: the rule the
    committed study's other runs were meshed with before "auto" became the default); the
    ``step_control`` of ``fe_model`` reaches every run."""
    from ..fem.campaign import FemJob

    runs = study()["runs"]
    if fe_model_materials is not None:
        known = sorted({spec["material"] for spec in runs.values()})
        for material in fe_model_materials:
            if material not in known:
                raise InputError(f"fe_model_materials: unknown material {material!r} "
                                 f"(allowed: {', '.join(known)})")
    names = [n for n in runs if only is None or n in only]
    # the checks first: on a finer mesh they are the longest runs, so they start at once
    plan = [(f"{n}@{m}", n, m) for n, m in (mesh_checks or {}).items()]
    plan += [(n, n, mesh) for n in names]
    jobs = []
    for label, name, run_mesh in plan:
        if name not in runs:
            raise InputError(f"run: unknown name {name!r} (allowed: {', '.join(runs)})")
        spec = runs[name]
        forces = preset_history(spec["history"], float(spec["peak_force"]))
        model = (fe_model if fe_model_materials is None
                 or spec["material"] in fe_model_materials else others_fe_model)
        # the step control is how every run is solved, not a material's model: it reaches all
        # (the committed study was made with fixed steps throughout)
        every = {k: v for k, v in (fe_model or {}).items() if k == "step_control"}
        jobs.append(FemJob(preset(spec["material"]), tuple(forces), mesh=run_mesh,
                           steps_per_segment=steps_per_segment, label=label,
                           **{**every, **(model or {})}))
    return plan, jobs


def single_load_jobs(job) -> list:
    """For a history job: one single load 0 -> F_k -> 0 per peak F_k of the history, on the
    history's own mesh (sized for its largest force) and FE model, so the two differ only by
    the path."""
    from ..fem.campaign import FemJob

    forces = list(job.forces)
    peaks = [f for i, f in enumerate(forces[1:-1], 1) if f > forces[i - 1] and f > forces[i + 1]]
    return [FemJob(job.material, (0.0, p, 0.0), mesh=job.mesh,
                   steps_per_segment=job.steps_per_segment, mesh_force=max(forces),
                   label=f"single load {p:.4g} N @ {job.label}", kinematics=job.kinematics,
                   mesh_rule=job.mesh_rule, step_rule=job.step_rule,
                   max_step_ratio=job.max_step_ratio, contact=job.contact, kernels=job.kernels,
                   step_control=job.step_control) for p in peaks]


def run_paper_histories(mesh: str = "default", cache_dir: str | Path = "out/cache/fem", *,
                        steps_per_segment: int | None = None, tolerance: float = DEFAULT_TOLERANCE,
                        workers: int | None = None, only: list[str] | None = None,
                        mesh_checks: dict[str, str] | None = None, single_loads: bool = True,
                        progress: bool = True,
                        fe_model: dict[str, Any] | None = None,
                        fe_model_materials: Sequence[str] | None = None,
                        others_fe_model: dict[str, Any] | None = None,
                        ) -> dict[str, PaperRun]:
    """Run (or read from the cache) the FE runs of the study and analyse their cycles.

    ``mesh_checks`` {run name: mesh}: the same run also on another mesh, in the same campaign,
    returned as ``"<name>@<mesh>"`` (a mesh-sensitivity check of the cyclic quantities).
    ``fe_model``, ``fe_model_materials``, ``others_fe_model``: the FE model, the materials it
    applies to and that of the other runs (``study_jobs``).
    ``single_loads``: also run, for every monotonically increasing history, a single load to
    each of its peaks on its mesh (the paper compares the two)."""
    from ..fem.campaign import run_campaign

    runs = study()["runs"]
    plan, jobs = study_jobs(mesh, steps_per_segment=steps_per_segment, only=only,
                            mesh_checks=mesh_checks, fe_model=fe_model,
                            fe_model_materials=fe_model_materials,
                            others_fe_model=others_fe_model)
    singles = {label: single_load_jobs(job)
               for (label, name, _), job in zip(plan, jobs, strict=True)
               if single_loads and runs[name]["history"] == "mono-increasing"}
    extra_jobs = [j for js in singles.values() for j in js]
    results = run_campaign(jobs + extra_jobs, cache_dir=cache_dir, workers=workers,
                           progress=progress)
    single_results = iter(results[len(jobs):])
    single_rows = {label: [_single_row(j, next(single_results)) for j in js]
                   for label, js in singles.items()}
    out = {}
    for (label, name, _), job, result in zip(plan, jobs, results[:len(jobs)], strict=True):
        cycles = result.summary["cycles"]
        out[label] = PaperRun(
            name=label, material_name=runs[name]["material"], material=job.material,
            history=runs[name]["history"], forces=list(job.forces), curve=result.curve,
            summary=result.summary,
            analysis=analyse(cycles, tolerance=tolerance, source=f"fe {label}"),
            extra={t: analyse(cycles, tolerance=t, source=f"fe {label}")
                   for t in EXTRA_TOLERANCES},
            single_loads=single_rows.get(label, []),
        )
    return out


def _single_row(job, result) -> dict[str, Any]:
    cycle = result.summary["cycles"][0]
    return {"peak_force_N": max(job.forces), "residual_approach_m": cycle["residual_approach_m"],
            "plastic_work_J": cycle["plastic_work_J"], "max_approach_m": cycle["max_approach_m"],
            "mesh_force_N": job.mesh_force, "cache_key": job.key()}


# --- findings ----------------------------------------------------------------------------------
def format_value(value: Any) -> str:
    """Compact text of a finding's value (number, dict, list, text) for tables."""
    if isinstance(value, float):
        return f"{value:.3g}"
    if isinstance(value, dict):
        return "; ".join(f"{k}: {format_value(v)}" for k, v in value.items())
    if isinstance(value, list):
        return ", ".join(format_value(v) for v in value)
    return "-" if value is None else str(value)


def _row(statement: str, quantity: str, our_value: Any, agrees: bool | None, *,
         paper_value: Any = None, rule: str = "", runs: list[str] | None = None) -> dict:
    return {"statement": statement, "quantity": quantity, "our_value": our_value,
            "agrees": agrees, "paper_value": paper_value, "rule": rule, "runs": runs or []}


def _missing(statement: str, quantity: str, needed: list[str], paper_value=None) -> dict:
    return {**_row(statement, quantity, f"not available: needs the runs {', '.join(needed)}",
                   None, paper_value=paper_value, runs=needed), "missing_runs": needed}


def _nc(run: PaperRun, which: str = "fitted") -> dict[str, Any]:
    c = run.analysis.critical_cycles[which]
    return {"residual": c["residual_increment"], "plastic_work": c["plastic_work"],
            "elastic_shakedown": c["elastic_shakedown"]}


def _g(x: Any) -> str:
    """A number as the sentences of the findings print it."""
    return "-" if x is None else (f"{x:.3g}" if isinstance(x, float) else str(x))


def _short(name: str) -> str:
    """'repeated-1MPa' -> '1 MPa', 'repeated-von-mises-10MPa' -> 'von Mises'."""
    if "von-mises" in name:
        return "von Mises"
    return name.rsplit("-", 1)[-1].replace("MPa", " MPa")


def _powers_text(powers: dict[str, Any]) -> str:
    return f"p = {_g(powers['residual'])} (residual), {_g(powers['plastic_work'])} (plastic work)"


def _span(values: list[float]) -> str:
    return "-" if not values else f"{min(values):.4g}-{max(values):.4g}"


SLOWER_RULE = ("both fitted power-law decay powers p (residual increment and plastic work "
               "ratios) smaller for the run claimed to need more cycles: then its Nc is larger "
               "at every tolerance small enough; Nc at a fixed loose tolerance can tie or invert "
               "because the ratios are relative to very different first cycles. A run whose "
               "residual increments are at the FE's resolution (< 1e-5 of cycle 1) from cycle 2 "
               "on shakes down at once and decays faster than any run with larger increments")


def _powers(run: PaperRun) -> dict[str, float | None]:
    a = run.analysis
    return {"residual": a.residual_fit.power if a.residual_fit else None,
            "plastic_work": a.plastic_work_fit.power if a.plastic_work_fit else None}


def _ratchetting_cycles(run: PaperRun) -> int:
    return ratchetting_cycles(run.analysis)


def _decays_slower(slow: PaperRun, fast: PaperRun) -> bool | None:
    """Whether both ratios of ``slow`` decay with a smaller power than those of ``fast``.

    A run whose residual increments are at the FE's resolution from cycle 2 on shakes down at
    once: it does not decay slower than one with resolvable increments (a power fitted to
    round-off says nothing)."""
    n_slow, n_fast = _ratchetting_cycles(slow), _ratchetting_cycles(fast)
    if n_slow == 0 or n_fast == 0:
        return None if n_slow == n_fast else n_slow > n_fast
    ps, pf = _powers(slow), _powers(fast)
    if None in ps.values() or None in pf.values():
        return None
    return all(ps[k] < pf[k] for k in ps)


def _secant_after(run: PaperRun) -> list[float]:
    """Reloading secant stiffness Fmax / (max approach_N - residual approach_{N-1}), N >= 2,
    and the first loading's Fmax / max approach_1 first."""
    rows = run.analysis.cycles
    k = [rows[0]["max_force_N"] / rows[0]["max_approach_m"]]
    for prev, row in zip(rows[:-1], rows[1:], strict=True):
        k.append(row["max_force_N"] / (row["max_approach_m"] - prev["residual_approach_m"]))
    return k


@dataclass(frozen=True)
class Context:
    """What a finding reads: the runs, the paper's numbers and the study's tolerances."""

    runs: dict[str, PaperRun]
    paper: dict[str, Any]
    tolerance: float

    @property
    def small(self) -> float:
        return float(self.paper["small_fraction"])


@dataclass(frozen=True)
class Finding:
    """One of the paper's statements: the quantity that tests it, the runs it needs and the
    check (``check(ctx) -> (our value, agrees, rule)``). ``quantity`` may hold ``{tol}``."""

    statement: str
    quantity: str
    needs: tuple[str, ...]
    check: Any
    paper_value: Any = None  # a callable of the paper's numbers, or None
    also_needs: str = ""  # what else the check needs when it returns None (besides ``needs``)
    says: Any = None  # our value -> one sentence with the numbers that decide the verdict

    def evaluate(self, ctx: Context) -> dict[str, Any]:
        quantity = self.quantity.format(tol=ctx.tolerance)
        paper_value = self.paper_value(ctx.paper) if self.paper_value else None
        missing = [*self.needs, *([self.also_needs] if self.also_needs else [])]
        if not set(self.needs) <= set(ctx.runs):
            return _missing(self.statement, quantity, missing, paper_value)
        outcome = self.check(ctx)
        if outcome is None:  # the runs are there but lack a part the check needs
            return _missing(self.statement, quantity, missing, paper_value)
        value, agrees, rule = outcome
        return {**_row(self.statement, quantity, value, agrees, paper_value=paper_value,
                       rule=rule, runs=list(self.needs)),
                "finding": self.says(value) if self.says else format_value(value)}


FINDINGS: list[Finding] = []


def finding(statement: str, quantity: str, needs, paper_value=None, also_needs: str = "",
            says=None):
    """Register the decorated check as a finding (in the order of the paper's section)."""
    def register(check):
        FINDINGS.append(Finding(statement, quantity, tuple(needs), check, paper_value,
                                also_needs, says))
        return check
    return register


REPEATED = ("repeated-10MPa", "repeated-1MPa")
DECREASING = ("mono-decreasing-10MPa", "mono-decreasing-1MPa")
INCREASING = ("mono-increasing-10MPa", "mono-increasing-1MPa")
MATERIALS = ("repeated-10MPa", "repeated-von-mises-10MPa")


def paper_findings(runs: dict[str, PaperRun]) -> list[dict[str, Any]]:
    """The paper's statements on loading history (``FINDINGS``), each with our number and a
    verdict; a statement whose runs are missing says so (``missing_runs``)."""
    tol = next(iter(runs.values())).analysis.tolerance if runs else DEFAULT_TOLERANCE
    ctx = Context(runs, study()["paper"], tol)
    return [f.evaluate(ctx) for f in FINDINGS]


# 1. hysteresis weakens after the first cycle
@finding("Hysteresis (residual approach, plastic work) weakens after the first cycle",
         "cycle 2 and last cycle over cycle 1: residual increment, plastic work; largest "
         "|ratio| of cycles 2..N", REPEATED,
         says=lambda v: "largest ratio of a later cycle to cycle 1: " + ", ".join(
             f"{_g(x['largest_later'])} ({_short(n)})" for n, x in v.items())
         + f" (agrees below {WEAKER:g})")
def _weakens(ctx: Context):
    value, ok = {}, True
    for n in REPEATED:
        c = ctx.runs[n].analysis.cycles
        largest = max(max(abs(x["residual_increment_ratio"]), abs(x["plastic_work_ratio"]))
                      for x in c[1:])
        value[n] = {"residual_cycle2": c[1]["residual_increment_ratio"],
                    "plastic_work_cycle2": c[1]["plastic_work_ratio"],
                    f"residual_cycle{len(c)}": c[-1]["residual_increment_ratio"],
                    f"plastic_work_cycle{len(c)}": c[-1]["plastic_work_ratio"],
                    "largest_later": largest}
        ok &= largest < WEAKER
    return value, ok, (f"every later cycle's ratios below {WEAKER:g} in magnitude (an order of "
                       "magnitude weaker than the first; magnitude because a residual "
                       "increment can change sign at the 1e-6 level)")


# 2. elastic shakedown eventually
@finding("Repeated loading ends in elastic shakedown",
         "state after the run and eventual state (tolerance {tol:g})", REPEATED,
         says=lambda v: "; ".join(f"{_short(n)}: {x['after_run']} after the run, "
                                  f"{x['eventual']} eventually" for n, x in v.items()))
def _ends_in_shakedown(ctx: Context):
    value = {n: {"after_run": ctx.runs[n].analysis.state,
                 "eventual": ctx.runs[n].analysis.eventual_state} for n in REPEATED}
    ok = all(ctx.runs[n].analysis.eventual_state == ELASTIC_SHAKEDOWN for n in REPEATED)
    return value, ok, "eventual state (fitted power laws) is elastic shakedown"


# 3. critical cycles
def _critical_cycles(name: str, key: str) -> None:
    @finding(f"Critical cycle Nc ({name}): residual approach, plastic work",
             "Nc fitted / measured at tolerance {tol:g} (and at "
             + ", ".join(f"{t:g}" for t in EXTRA_TOLERANCES) + ")", [name],
             paper_value=lambda paper: paper[key],
             says=lambda v: f"fitted Nc {_g(v['fitted']['residual'])} (residual), "
                            f"{_g(v['fitted']['plastic_work'])} (plastic work); measured "
                            f"{_g(v['measured']['residual'])}, "
                            f"{_g(v['measured']['plastic_work'])}")
    def check(ctx: Context):
        r = ctx.runs[name]
        value = {"fitted": _nc(r), "measured": _nc(r, "measured"),
                 **{f"fitted_tol_{t:g}": {
                     "residual": a.critical_cycles["fitted"]["residual_increment"],
                     "plastic_work": a.critical_cycles["fitted"]["plastic_work"]}
                    for t, a in r.extra.items()}}
        pr, pw = ctx.paper[key]
        fr, fw = value["fitted"]["residual"], value["fitted"]["plastic_work"]
        ok = all(v is not None and p / 2 <= v <= 2 * p for v, p in ((fr, pr), (fw, pw)))
        return value, ok, ("fitted Nc within a factor 2 of the paper's (the paper does not "
                           "state its tolerance)")


_critical_cycles("repeated-10MPa", "critical_cycles_10MPa")
_critical_cycles("repeated-1MPa", "critical_cycles_1MPa")


@finding("The stronger sphere (sigma_c = 10 MPa) shakes down in fewer cycles than 1 MPa",
         "fitted decay powers p (residual, plastic work) and Nc of elastic shakedown at each "
         "tolerance", REPEATED,
         paper_value=lambda paper: {"10MPa": max(paper["critical_cycles_10MPa"]),
                                    "1MPa": max(paper["critical_cycles_1MPa"])},
         says=lambda v: f"10 MPa {_powers_text(v['powers_10MPa'])}; 1 MPa "
                        f"{_powers_text(v['powers_1MPa'])}; Nc of elastic shakedown "
                        f"{_g(v['10MPa'])} and {_g(v['1MPa'])}")
def _stronger_faster(ctx: Context):
    a, b = ctx.runs["repeated-10MPa"], ctx.runs["repeated-1MPa"]
    value = {"10MPa": _nc(a)["elastic_shakedown"], "1MPa": _nc(b)["elastic_shakedown"],
             **{f"tol_{t:g}": {n: ctx.runs[n].extra[t].critical_cycles["fitted"][
                 "elastic_shakedown"] for n in REPEATED} for t in EXTRA_TOLERANCES},
             "powers_10MPa": _powers(a), "powers_1MPa": _powers(b)}
    return value, _decays_slower(b, a), SLOWER_RULE


@finding("The weaker sphere (1 MPa) ratchets longer under repeated loading",
         f"cycles after the first with a residual increment above {RESOLUTION:g} of cycle 1's "
         "residual approach; last-cycle residual increment ratio", REPEATED,
         says=lambda v: "ratchetting cycles after the first: " + ", ".join(
             f"{c} ({_short(n)})" for n, c in v["ratchetting_cycles"].items())
         + "; last residual increment ratio " + ", ".join(
             f"{_g(r)} ({_short(n)})" for n, r in v["last_ratio"].items()))
def _weaker_ratchets_longer(ctx: Context):
    count = {n: _ratchetting_cycles(ctx.runs[n]) for n in REPEATED}
    last = {n: ctx.runs[n].analysis.cycles[-1]["residual_increment_ratio"] for n in REPEATED}
    weak, strong = "repeated-1MPa", "repeated-10MPa"
    ok = (count[weak] > count[strong]
          or (count[weak] == count[strong] > 0 and last[weak] > last[strong]))
    return ({"ratchetting_cycles": count, "last_ratio": last}, ok,
            "more ratchetting cycles for 1 MPa (tie: larger last-cycle increment ratio)")


# 4. reloading stiffer after higher loads (monotonically increasing history)
@finding("Reloading curves are stiffer after higher previous loads",
         "secant stiffness of each loading branch up to the first peak (100 N) vs prior peak",
         ["mono-increasing-10MPa"],
         says=lambda v: "secant stiffness by prior peak: " + ", ".join(
             f"{_g(x['secant_stiffness_N_per_m'])} N/m after {_g(x['prior_peak_N'])} N"
             for x in v))
def _stiffer_after_higher_loads(ctx: Context):
    r = ctx.runs["mono-increasing-10MPa"]
    st = reloading_stiffness(r.curve, r.windows, r.analysis.cycles[0]["max_force_N"])
    value = [{"cycle": s["cycle"], "prior_peak_N": s["prior_peak_N"],
              "secant_stiffness_N_per_m": s["secant_stiffness_N_per_m"]} for s in st]
    k = [s["secant_stiffness_N_per_m"] for s in st]
    ok = all(v is not None for v in k) and all(b > a for a, b in zip(k[:-1], k[1:],
                                                                    strict=True))
    return value, ok, "stiffness rises with every higher prior peak (cycle 1 = virgin)"


@finding("Subsequent curves are stiffer than the previous ones, especially when the yield "
         "strength is high",
         "reloading secant stiffness Fmax/(dmax_N - dres_{{N-1}}): cycle 2 over first loading, "
         "last cycle over cycle 2", REPEATED,
         says=lambda v: "reload stiffness, last cycle over cycle 2: " + ", ".join(
             f"{_g(x['last_over_cycle2'])} ({_short(n)})" for n, x in v.items()))
def _subsequent_stiffer(ctx: Context):
    value, growth = {}, {}
    for m in REPEATED:
        k = _secant_after(ctx.runs[m])
        value[m] = {"cycle2_over_first_loading": k[1] / k[0], "last_over_cycle2": k[-1] / k[1]}
        growth[m] = k[-1] / k[1] - 1.0
    ok = all(g > 0 for g in growth.values()) and growth["repeated-10MPa"] > growth[
        "repeated-1MPa"]
    return value, ok, "reload stiffness grows from cycle 2 to the last for both, more for 10 MPa"


# 5. monotonically decreasing: reloading negligible
def _decreasing_fractions(run: PaperRun) -> tuple[float, float]:
    """Sum of the plastic work of cycles 2.. over cycle 1's; growth of the residual approach
    after cycle 1 over cycle 1's."""
    c = run.analysis.cycles
    return (sum(x["plastic_work_J"] for x in c[1:]) / c[0]["plastic_work_J"],
            (c[-1]["residual_approach_m"] - c[0]["residual_approach_m"])
            / c[0]["residual_approach_m"])


def _decreasing_small(name: str, strength: str) -> None:
    @finding(f"Monotonically decreasing loading ({strength}): reloading plastic work and "
             "residual approach are small compared with the first cycle",
             "sum over cycles 2-7 over cycle 1: plastic work; residual approach growth", [name],
             paper_value=lambda paper: {
                 "plastic_work": paper[f"decreasing_plastic_work_fraction_{strength}"],
                 "residual": paper[f"decreasing_residual_fraction_{strength}"]},
             says=lambda v: f"later cycles' plastic work {_g(v['plastic_work'])} and residual "
                            f"growth {_g(v['residual'])} of cycle 1's ({v['state']})")
    def check(ctx: Context):
        wp, res = _decreasing_fractions(ctx.runs[name])
        value = {"plastic_work": wp, "residual": res, "state": ctx.runs[name].analysis.state}
        return value, abs(wp) < ctx.small and abs(res) < ctx.small, f"both below {ctx.small:g}"


_decreasing_small("mono-decreasing-10MPa", "10MPa")
_decreasing_small("mono-decreasing-1MPa", "1MPa")


@finding("Under decreasing loading the weaker sphere (1 MPa) shakes down more easily",
         "reloading plastic work and residual growth fractions, 1 MPa vs 10 MPa", DECREASING,
         says=lambda v: "; ".join(f"{_short(n)}: plastic work {_g(x['plastic_work'])}, residual "
                                  f"{_g(x['residual'])} of cycle 1's" for n, x in v.items()))
def _weaker_shakes_down_more_easily(ctx: Context):
    frac = {m: _decreasing_fractions(ctx.runs[m]) for m in DECREASING}
    ok = all(a < b for a, b in zip(frac[DECREASING[1]], frac[DECREASING[0]], strict=True))
    return ({m: {"plastic_work": f[0], "residual": f[1]} for m, f in frac.items()}, ok,
            "both fractions smaller for 1 MPa")


# 6. no shakedown under monotonically increasing loading
def _no_shakedown(name: str) -> None:
    @finding(f"No shakedown under monotonically increasing loading ({name})",
             "state after the run, last-cycle residual increment ratio", [name],
             says=lambda v: f"{v['state']} after the run; the last cycle's residual increment "
                            f"is {_g(v['last_residual_increment_ratio'])} x cycle 1's")
    def check(ctx: Context):
        a = ctx.runs[name].analysis
        value = {"state": a.state, "eventual": a.eventual_state,
                 "last_residual_increment_ratio": a.cycles[-1]["residual_increment_ratio"]}
        return value, a.state == RATCHETTING, ("state is ratchetting (residual increments do "
                                               "not decay)")


def _versus_single(name: str) -> None:
    @finding(f"Monotonically increasing loading ({name}): residual approach per cycle a "
             "little larger, plastic work per cycle lower than a single load to the same level",
             "cycle k of the history over a single load 0 -> F_k -> 0 on the same mesh, k >= 2: "
             "residual approach ratio; plastic work ratio", [name],
             also_needs=f"single loads of {name}",
             says=lambda v: "cycles 2+ over single loads: residual "
                            f"{_span(v['residual_ratio_by_cycle'][1:])}, plastic work "
                            f"{_span(v['plastic_work_ratio_by_cycle'][1:])}")
    def check(ctx: Context):
        run = ctx.runs[name]
        return _versus_single_loads(run) if run.single_loads else None


for _name in INCREASING:
    _no_shakedown(_name)
for _name in INCREASING:
    _versus_single(_name)
del _name


# 7. Drucker-Prager vs von Mises
@finding("Drucker-Prager grains need more cycles to shake down than von Mises metals",
         "fitted decay powers p (residual, plastic work); Nc of elastic shakedown, fitted and "
         "measured (tolerance {tol:g} and smaller)", MATERIALS,
         paper_value=lambda paper: {
             "von_mises": paper["von_mises_shakedown_cycle"],
             "drucker_prager_more_than": paper["drucker_prager_shakedown_cycles_more_than"]},
         says=lambda v: f"Drucker-Prager {_powers_text(v['powers_drucker_prager'])}; von Mises "
                        f"{_powers_text(v['powers_von_mises'])}")
def _drucker_prager_slower(ctx: Context):
    dp, vm = ctx.runs[MATERIALS[0]], ctx.runs[MATERIALS[1]]
    value = {"drucker_prager": {"fitted": _nc(dp), "measured": _nc(dp, "measured")},
             "von_mises": {"fitted": _nc(vm), "measured": _nc(vm, "measured")},
             **{f"fitted_tol_{t:g}": {
                 "drucker_prager": dp.extra[t].critical_cycles["fitted"]["elastic_shakedown"],
                 "von_mises": vm.extra[t].critical_cycles["fitted"]["elastic_shakedown"]}
                for t in EXTRA_TOLERANCES},
             "powers_drucker_prager": _powers(dp), "powers_von_mises": _powers(vm)}
    return value, _decays_slower(dp, vm), SLOWER_RULE


# "A little larger": the residual approach of the history at most this much above a single load's.
A_LITTLE = 0.10


def _versus_single_loads(run: PaperRun):
    cycles = run.analysis.cycles
    residual, work = [], []
    for c in cycles:
        single = next((s for s in run.single_loads
                       if abs(s["peak_force_N"] - c["max_force_N"]) <= 1e-3 * c["max_force_N"]),
                      None)
        if single is None:  # no single load to this cycle's peak
            continue
        residual.append(c["residual_approach_m"] / single["residual_approach_m"])
        work.append(c["plastic_work_J"] / single["plastic_work_J"])
    later_r, later_w = residual[1:], work[1:]
    ok = (len(later_r) > 0 and all(1.0 < r <= 1.0 + A_LITTLE for r in later_r)
          and all(w < 1.0 for w in later_w))
    value = {"residual_ratio_by_cycle": residual, "plastic_work_ratio_by_cycle": work}
    return value, ok, (f"cycles 2+: residual ratio in (1, {1 + A_LITTLE:g}] and plastic work "
                       "ratio < 1 (cycle 1 is the single load itself, ratio 1)")


__all__ = ["PaperRun", "paper_findings", "run_paper_histories", "single_load_jobs", "study",
           "study_jobs"]


def write_study(directory: str | Path, runs: dict[str, PaperRun],
                record: dict[str, Any]) -> tuple[list[dict[str, Any]], list[str]]:
    """Write the study's results: one JSON per run, cycles.csv, findings.json (with
    ``record``, the provenance) and findings.csv. Returns the findings and the file names."""
    from .cycles import write_cycles_csv

    directory = Path(directory)
    files = []
    for name, run in runs.items():
        write_json_atomic(directory / f"{name}.json", run.to_dict())
        files.append(f"{name}.json")
    write_cycles_csv(directory / "cycles.csv", {name: run.analysis for name, run in runs.items()})
    findings = paper_findings(runs)
    write_json_atomic(directory / "findings.json",
                      {"findings": findings, "runs": list(runs), "provenance": record})
    write_csv(directory / "findings.csv", {
        "statement": np.array([f["statement"] for f in findings], dtype=object),
        "agrees": np.array(["n/a" if f["agrees"] is None else str(f["agrees"])
                            for f in findings], dtype=object),
        "finding": np.array([f.get("finding", f["our_value"]) for f in findings], dtype=object),
        "rule": np.array([f["rule"] for f in findings], dtype=object),
    })
    return findings, files + ["cycles.csv", "findings.json", "findings.csv"]
