"""Acceptance of a calibrated law on FE runs (docs/model.md §7).

The law is driven along the FE run's own approach path (``Contact.update`` over the FE
``approach_m`` column, as a DEM code would drive it) and its force is compared with the FE force:

* force error: RMS of (law - FE) along the path, as % of the run's peak force. The RMS is taken
  over the path length (weights |d approach|), so it does not depend on how the FE placed its
  load steps (they crowd near first yield and near zero force);
* residual approach: at every return of the FE force to zero, |law - FE| as % of the FE value.

``held_out_jobs`` are FE runs the calibration never sees (data/calibration.toml): other peak
loads, a partial unload-reload, a new envelope after a reload. The calibration runs themselves
are compared the same way ("fitted": the law reproduces the curves it came from).

    comparisons = run_acceptance(params, material, mesh="default")
    table = acceptance_table(comparisons)          # JSON-ready
    write_comparison_data(comparisons, "P.acceptance")   # CSV per run
    figures = draw_comparison_figures(comparisons, "P.acceptance")  # PNG per run (figures.Figure)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..fem.campaign import DEFAULT_CACHE, FemJob, run_campaign
from ..fem.identity import run_key
from ..fem.result import FemResult
from ..files import write_csv
from ..grain.material import Material
from ..law import Contact, LawParams
from .campaign import force_range, settings, shared_mesh_force


@dataclass
class Comparison:
    """FE and law along one FE run's approach path."""

    name: str
    kind: str  # "fitted" (a calibration run) or "held-out"
    description: str
    forces: tuple[float, ...]  # the FE force history (N)
    approach: np.ndarray
    fe_force: np.ndarray
    law_force: np.ndarray
    law_residual: np.ndarray  # the law's residual approach of its envelope at each point
    cache_key: str
    residuals: list[dict[str, float]] = field(default_factory=list)

    @property
    def peak_force(self) -> float:
        return float(np.max(self.fe_force))

    @property
    def force_rms_percent(self) -> float:
        """RMS of the force error over the path length, % of the peak force."""
        weights = path_weights(self.approach)
        error = self.law_force - self.fe_force
        rms = float(np.sqrt(np.sum(weights * error**2) / np.sum(weights)))
        return 100.0 * rms / self.peak_force

    @property
    def force_max_percent(self) -> float:
        return 100.0 * float(np.max(np.abs(self.law_force - self.fe_force))) / self.peak_force

    @property
    def residual_error_percent(self) -> float | None:
        """Largest residual-approach error over the run's returns to zero force (%)."""
        if not self.residuals:
            return None
        return max(r["error_percent"] for r in self.residuals)


def path_weights(approach: np.ndarray) -> np.ndarray:
    """Trapezoid weights of each point along the path, by |d approach|."""
    step = np.abs(np.diff(approach))
    weights = np.zeros_like(approach)
    weights[:-1] += 0.5 * step
    weights[1:] += 0.5 * step
    if not np.any(weights > 0):
        weights[:] = 1.0
    return weights


def compare(params: LawParams, job: FemJob, result: FemResult, *, name: str, kind: str,
            description: str = "") -> Comparison:
    """Drive the law along the FE approach path and compare forces and residual approaches."""
    approach = np.asarray(result.curve["approach_m"], dtype=float)
    fe_force = np.asarray(result.curve["force_N"], dtype=float)
    contact = Contact(params)
    law_force = np.empty_like(approach)
    law_residual = np.empty_like(approach)
    for i, a in enumerate(approach):
        law_force[i] = contact.update(float(a))[0]
        law_residual[i] = contact.state.residual_approach + contact.state.ratchet_shift
    index = {int(s): i for i, s in enumerate(result.curve["step"])}
    residuals = []
    for n, cycle in enumerate(result.summary["cycles"], 1):
        fe = cycle["residual_approach_m"]
        if fe is None or fe <= 0.0:
            continue
        law = float(law_residual[index[cycle["steps"][1]]])
        residuals.append({"cycle": n, "peak_force_N": cycle["max_force_N"],
                          "fe_residual_approach_m": fe, "law_residual_approach_m": law,
                          "error_percent": 100.0 * abs(law - fe) / fe})
    return Comparison(name=name, kind=kind, description=description, forces=job.forces,
                      approach=approach, fe_force=fe_force, law_force=law_force,
                      law_residual=law_residual, cache_key=run_key(result, job.identity()),
                      residuals=residuals)


def held_out_jobs(material: Material, mesh: str = "default",
                  steps_per_segment: int | None = None,
                  max_force: float | None = None,
                  fe_model: dict[str, str] | None = None,
                  mesh_force: float | None = None,
                  ) -> list[tuple[dict[str, Any], FemJob]]:
    """The held-out FE runs of data/calibration.toml for this material's force range, on the
    calibration's shared mesh (sized for ``mesh_force``, default the range's top)."""
    low, high = force_range(material, max_force)
    mesh_force = shared_mesh_force([high]) if mesh_force is None else float(mesh_force)
    jobs = []
    for spec in settings()["acceptance"]["runs"]:
        peak = low * (high / low) ** float(spec["u"])
        forces = tuple(float(f) * peak for f in spec["forces"])
        jobs.append((spec, FemJob(material, forces, mesh=mesh,
                                  steps_per_segment=steps_per_segment,
                                  label=f"{spec['name']} F={peak:.4g}N",
                                  mesh_force=None if mesh_force is None
                                  else max(mesh_force, *forces), **(fe_model or {}))))
    return jobs


def run_acceptance(params: LawParams, material: Material, *, mesh: str = "default",
                   steps_per_segment: int | None = None, max_force: float | None = None,
                   cache_dir=DEFAULT_CACHE, scheduler: str | None = None,
                   workers: int | None = None, progress: bool = True,
                   fe_model: dict[str, str] | None = None,
                   mesh_force: float | None = None) -> list[Comparison]:
    """Run (or read from the cache) the held-out FE runs (with the calibration's FE model and
    mesh) and compare the law with each."""
    specs = held_out_jobs(material, mesh, steps_per_segment, max_force, fe_model, mesh_force)
    results = run_campaign([job for _, job in specs], cache_dir, scheduler=scheduler,
                           workers=workers, progress=progress)
    return [compare(params, job, result, name=spec["name"], kind="held-out",
                    description=spec["description"])
            for (spec, job), result in zip(specs, results, strict=True)]


def acceptance_table(comparisons: list[Comparison]) -> dict[str, Any]:
    """The acceptance table (JSON-ready): per run, the errors against the goals."""
    goals = settings()["acceptance"]
    rows = []
    for c in comparisons:
        res = c.residual_error_percent
        rows.append({
            "name": c.name,
            "kind": c.kind,
            "description": c.description,
            "forces_N": list(c.forces),
            "peak_force_N": c.peak_force,
            "force_rms_percent_of_peak": c.force_rms_percent,
            "force_max_percent_of_peak": c.force_max_percent,
            "residual_approach_error_percent": res,
            "residuals": c.residuals,
            "meets_force_goal": c.force_rms_percent <= goals["force_rms_goal_percent"],
            "meets_residual_goal": None if res is None else res <= goals["residual_goal_percent"],
            "cache_key": c.cache_key,
        })
    held = [r for r in rows if r["kind"] == "held-out"]
    return {
        "goals": {"force_rms_percent_of_peak": goals["force_rms_goal_percent"],
                  "residual_approach_error_percent": goals["residual_goal_percent"]},
        "definition": "law driven along each FE run's approach path; force RMS over the path "
                      "length (|d approach| weights) as % of the run's peak force; residual "
                      "approach error at each return to zero force, % of the FE value",
        "runs": rows,
        "held_out_all_met": bool(held) and all(
            r["meets_force_goal"] and r["meets_residual_goal"] is not False for r in held),
    }


def _columns(c: Comparison) -> dict[str, np.ndarray]:
    return {"approach_m": c.approach, "fe_force_N": c.fe_force, "law_force_N": c.law_force,
            "law_residual_approach_m": c.law_residual}


def write_comparison_data(comparisons: list[Comparison], directory: str | Path) -> list[Path]:
    """One CSV per run: approach, FE force, law force, law residual approach."""

    directory = Path(directory)
    paths = []
    for c in comparisons:
        path = directory / f"{c.name}.csv"
        write_csv(path, _columns(c))
        paths.append(path)
    return paths


def draw_comparison_figures(comparisons: list[Comparison], directory: str | Path) -> list:
    """FE vs law force-approach, one PNG per run (and its CSV), as figures.Figure records."""
    import matplotlib.pyplot as plt

    from ..figures import Figure, save_figure

    directory = Path(directory)
    figures = []
    for c in comparisons:
        fig, ax = plt.subplots(figsize=(5.2, 3.8))
        ax.plot(c.approach * 1e3, c.fe_force, "o", ms=3, mfc="none", color="0.35", label="FE")
        ax.plot(c.approach * 1e3, c.law_force, "-", lw=1.4, color="tab:red",
                label="law (driven by the FE approach)")
        ax.set_xlabel("approach δ (mm, ball–ball)")
        ax.set_ylabel("normal force F (N)")
        res = c.residual_error_percent
        ax.set_title(f"{c.name}: RMS {c.force_rms_percent:.2f} % of peak"
                     + ("" if res is None else f", δres error {res:.1f} %"), fontsize=9)
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(alpha=0.3)
        figure = Figure(
            name=c.name, title=f"FE vs law: {c.name}",
            caption=f"{c.description or c.kind}; force history "
                    f"{', '.join(f'{f:.4g}' for f in c.forces)} N. The law is driven along the "
                    "FE approach path.",
            data=_columns(c),
        )
        save_figure(fig, directory, figure)
        figures.append(figure)
    return figures
