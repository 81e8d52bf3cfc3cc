"""FE loading curve in the von Mises limit against Kogut & Etsion (2002) and Jackson & Green (2005).

docs/model.md §5 verification: an elastic-perfectly plastic sphere (beta = 0, E/sigma_c = 1000,
nu = 0.3, the ``von-mises`` preset) pressed by a rigid flat from 1 to 50 critical interferences.
The FE half model is exactly the fits' problem (one deformable sphere, rigid frictionless flat);
its interference is the ball-wall one, omega = approach / 2. Each fit is normalised by its own
critical interference and load (geocontact.verification.published_fits); the figure and the
table use the Jackson-Green normalisation, the Kogut-Etsion curve is converted to it.

    PYTHONPATH=src .venv/bin/python scripts/verify_von_mises.py [--mesh default] [--steps 40]

Writes docs/verification/von_mises.{png,csv,md,json}.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from geocontact.fem.run import run_history
from geocontact.files import provenance, write_csv, write_json_atomic, write_text_atomic
from geocontact.grain.hertz import incipient_yield
from geocontact.grain.material import preset
from geocontact.verification import published_fits as fits

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"
TABLE_AT = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0)  # omega / omega_c of the table
LARGEST = 50.0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", default="default")
    parser.add_argument("--steps", type=int, default=40, help="load steps per segment")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)

    material = preset("von-mises")
    jg = fits.jackson_green_critical(material)
    ke = fits.kogut_etsion_critical(material)
    # Force that carries the sphere past 50 omega_c with a margin (JG at 50 omega_c x 1.2);
    # run_history sizes the mesh (largest contact radius) from this peak force.
    peak = 1.2 * float(fits.jackson_green_load(material, LARGEST)) * jg.force
    started = time.perf_counter()
    # the "yield" meshes and fixed steps (the defaults before issue 36), on which the documented
    # comparison was made
    result = run_history(material, [0.0, peak], mesh=args.mesh, steps_per_segment=args.steps,
                         write_fields=False, mesh_rule="yield", step_control="fixed")
    wall = time.perf_counter() - started
    c = result.curve
    omega = c["approach_m"] / 2.0  # ball-wall interference of the half model
    force = c["force_N"]
    if omega.max() < LARGEST * jg.interference:
        raise SystemExit(f"FE run stopped at {omega.max() / jg.interference:.1f} omega_c")

    w = omega / jg.interference
    fe = force / jg.force
    ke_on_jg = fits.kogut_etsion_load(omega / ke.interference) * ke.force / jg.force
    jg_load = fits.jackson_green_load(material, w)
    analytic = incipient_yield(material)  # ball-ball approach; omega_y = approach / 2

    at = np.array(TABLE_AT)
    fe_at = fits.fe_load_at(omega, force, at * jg.interference) / jg.force
    jg_at = fits.jackson_green_load(material, at)
    ke_at = fits.kogut_etsion_load(at * jg.interference / ke.interference) * ke.force / jg.force

    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(args.out / "von_mises.csv", {
        "step": c["step"], "force_N": force, "interference_m": omega,
        "contact_radius_m": c["contact_radius_m"], "w_over_wc_JG": w, "P_over_Pc_FE": fe,
        "P_over_Pc_JG": jg_load, "P_over_Pc_KE": ke_on_jg,
        "yielded_contact_fraction": c["yielded_contact_fraction"],
        "yielded_core_fraction": c["yielded_core_fraction"],
    })
    rows = []
    for k, x in enumerate(TABLE_AT):
        rows.append({"w_over_wc": x, "FE": float(fe_at[k]), "JG": float(jg_at[k]),
                     "KE": float(ke_at[k]), "FE_vs_JG": float(fe_at[k] / jg_at[k] - 1.0),
                     "FE_vs_KE": float(fe_at[k] / ke_at[k] - 1.0)})
    s = result.summary
    record = {
        **provenance("scripts/verify_von_mises.py", {
            "material": material.to_dict(), "mesh": args.mesh, "steps_per_segment": args.steps,
            "peak_force_N": peak}),
        "critical_JG": {"interference_m": jg.interference, "force_N": jg.force,
                        "C": fits.jackson_green_c(material.poissons_ratio)},
        "critical_KE": {"interference_m": ke.interference, "force_N": ke.force},
        "analytic_first_yield": {"interference_m": analytic.approach / 2.0,
                                 "force_N": analytic.force,
                                 "p0_over_sigma_c": 1.0 / analytic.dp_factor},
        "fe_first_yield": {"interference_m": s["first_yield_approach_m"] / 2.0,
                           "force_N": s["first_yield_force_N"]},
        "fe_fully_plastic": {"force_N": s["fully_plastic_force_N"],
                             "interference_m": (s["fully_plastic_approach_m"] / 2.0
                                                if s["fully_plastic_approach_m"] else None)},
        "table": rows,
        "fe": {"steps": s["steps"], "elements": s["mesh"]["elements"],
               "nodes": s["mesh"]["nodes"], "wall_time_s": wall,
               "largest_contact_radius_over_R": float(c["contact_radius_m"].max()
                                                      / material.radius)},
    }
    write_json_atomic(args.out / "von_mises.json", record)
    write_text_atomic(args.out / "von_mises.md", _table(record))
    _figure(args.out / "von_mises.png", w, fe, material, jg, ke, analytic, s)
    print(_table(record))
    return 0


def _table(record: dict) -> str:
    jg, ke = record["critical_JG"], record["critical_KE"]
    y, fy = record["analytic_first_yield"], record["fe_first_yield"]
    lines = [
        "# von Mises sphere on a rigid flat: FE against Kogut-Etsion and Jackson-Green",
        "",
        f"Made by `{record['command']}` (geocontact {record['geocontact_version']}, "
        f"{record['created_utc']}); data in von_mises.csv, inputs in von_mises.json.",
        "",
        f"omega_c (JG) = {jg['interference_m']:.4e} m, P_c (JG) = {jg['force_N']:.3f} N "
        f"(C = {jg['C']:.4f}); omega_c (KE) = {ke['interference_m']:.4e} m, "
        f"P_c (KE) = {ke['force_N']:.3f} N; analytic first yield (geocontact.grain.hertz, "
        f"p0 = {y['p0_over_sigma_c']:.4f} sigma_c): omega_y = {y['interference_m']:.4e} m, "
        f"F_y = {y['force_N']:.3f} N; FE first yield: omega = {fy['interference_m']:.4e} m, "
        f"F = {fy['force_N']:.3f} N.",
        "",
        "| omega/omega_c | P/P_c FE | P/P_c JG | P/P_c KE | FE vs JG | FE vs KE |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in record["table"]:
        lines.append(f"| {r['w_over_wc']:g} | {r['FE']:.3f} | {r['JG']:.3f} | {r['KE']:.3f} | "
                     f"{100 * r['FE_vs_JG']:+.1f} % | {100 * r['FE_vs_KE']:+.1f} % |")
    fe = record["fe"]
    lines += ["", f"FE: {record['inputs']['mesh']} mesh, {fe['elements']} elements, "
              f"{fe['steps']} load steps, {fe['wall_time_s']:.0f} s; largest contact radius "
              f"a/R = {fe['largest_contact_radius_over_R']:.4f}.", ""]
    return "\n".join(lines)


def _figure(path, w, fe, material, jg, ke, analytic, summary) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geocontact.files import atomic_path

    grid = np.geomspace(0.1, LARGEST * 1.1, 300)
    fig, (ax, dev) = plt.subplots(2, 1, figsize=(6.4, 6.4), sharex=True,
                                  gridspec_kw={"height_ratios": [2.2, 1]})
    ax.loglog(w[w > 0], fe[w > 0], "o", ms=3.5, color="k", label="geocontact FE (this run)")
    ax.loglog(grid, fits.jackson_green_load(material, grid), "-", color="tab:blue",
              label="Jackson & Green (2005)")
    ke_grid = fits.kogut_etsion_load(grid * jg.interference / ke.interference) \
        * ke.force / jg.force
    ax.loglog(grid, ke_grid, "--", color="tab:red", label="Kogut & Etsion (2002)")
    ax.loglog(grid, grid**1.5, ":", color="0.5", label="Hertz")
    wy = analytic.approach / 2.0 / jg.interference
    ax.loglog([wy], [analytic.force / jg.force], "s", mfc="none", color="tab:green", ms=8,
              label="analytic first yield (geocontact.grain.hertz)")
    ax.set_ylabel(r"$P/P_c$")
    ax.set_title(r"von Mises sphere on a rigid flat, $E/\sigma_c$ = 1000, $\nu$ = 0.3")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    shown = w >= 1.0
    ke_w = fits.kogut_etsion_load(w * jg.interference / ke.interference) * ke.force / jg.force
    dev.semilogx(w[shown], 100 * (fe[shown] / fits.jackson_green_load(material, w[shown]) - 1),
                 "o-", ms=3, color="tab:blue", label="FE vs JG")
    dev.semilogx(w[shown], 100 * (fe[shown] / ke_w[shown] - 1), "s-", ms=3, color="tab:red",
                 label="FE vs KE")
    dev.axhline(0.0, color="0.5", lw=0.8)
    dev.set_xlim(0.1, LARGEST * 1.1)
    dev.set_xlabel(r"$\omega/\omega_c$ (JG normalisation)")
    dev.set_ylabel("FE / fit - 1 (%)")
    dev.grid(True, which="both", alpha=0.3)
    dev.legend(fontsize=8)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
