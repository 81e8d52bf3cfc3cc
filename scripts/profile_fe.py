"""Where an FE run's time goes (issue 12): the reference cycle 0 -> F -> 0 under cProfile, with
the time of the sparse factorisation, the element kernels (assembly of stiffness and internal
force), the return mapping and the triangular solves, and the run's steps, Newton iterations
and linear solves.

    PYTHONPATH=src .venv/bin/python scripts/profile_fe.py [--mesh default] [--force 6000]
        [--linear-solver fast|reference]

Finite strain (issue 36): ``--material reference-weak --kinematics finite --mesh-rule contact
--force 3000 --load-only --solve-steps 6`` builds the weak grain's mesh of 0 -> 3000 N (22 624
unknowns, as ``geocontact fem --mesh-rule contact`` does) and solves only the first 6 load steps
of its schedule (``run._advance``, cutbacks included) instead of the whole run; ``--kernels
compiled --factoriser NAME`` solves them on ``fem.compiled`` instead of the numpy path. The rows
then include the finite-strain kernels and the time per Newton iteration.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

from geocontact.fem.compiled import FACTORISERS, compiled_solver
from geocontact.fem.finite_strain import FiniteStrainSolver
from geocontact.fem.result import STEPS_PER_SEGMENT
from geocontact.fem.run import (
    _advance,
    history_mesh,
    load_schedule,
    run_history,
    smallest_resolved_force,
)
from geocontact.grain.hertz import incipient_yield
from geocontact.grain.material import load_material

# (label, where the time is spent: a pstats function key's file suffix and function name)
PARTS = (
    ("sparse LU factorisation (SuperLU gstrf)", ("~", "<built-in method scipy.sparse.linalg."
                                                 "_dsolve._superlu.gstrf>")),
    ("triangular solves (SuperLU solve)", ("~", "<method 'solve' of 'SuperLU' objects>")),
    ("tangent stiffness assembly (solver.stiffness)", ("fem/solver.py", "stiffness")),
    ("fast path: factorisation (linear_algebra.factorise)", ("fem/linear_algebra.py",
                                                             "factorise")),
    ("fast path: element matrices (solver.element_matrices)", ("fem/solver.py",
                                                              "element_matrices")),
    ("fast path: bordered system (linear_algebra._bordered_system)",
     ("fem/linear_algebra.py", "_bordered_system")),
    ("internal force (solver.internal_force)", ("fem/solver.py", "internal_force")),
    ("return mapping (plasticity.return_mapping)", ("fem/plasticity.py", "return_mapping")),
    ("contact forces (contact_outputs.contact_forces)", ("fem/contact_outputs.py",
                                                        "contact_forces")),
    ("finite strain: whole evaluation (_evaluate)", ("fem/finite_strain.py", "_evaluate")),
    ("finite strain: kinematics", ("fem/finite_strain.py", "kinematics")),
    ("finite strain: constitutive update (FiniteUpdate)", ("fem/finite_strain.py", "__init__")),
    ("finite strain: material tangent", ("fem/finite_strain.py", "material_tangent")),
    ("finite strain: element products", ("fem/finite_strain.py", "_element_products")),
    ("finite strain: internal force (_force)", ("fem/finite_strain.py", "_force")),
    ("finite strain: factorisation (_factor)", ("fem/finite_strain.py", "_factor")),
    ("compiled: kernels (fem/compiled.py _evaluate)", ("fem/compiled.py", "_evaluate")),
    ("compiled: factorisation (fem/compiled.py _factor)", ("fem/compiled.py", "_factor")),
    ("compiled: bordered system (scatter)", ("fem/compiled.py", "_bordered_data")),
    ("compiled: a contact set's entry map (_plan)", ("fem/compiled.py", "_plan")),
    ("a contact set's index maps (linear_algebra._reduced)", ("fem/linear_algebra.py",
                                                              "_reduced")),
    ("linear predictor's strains (solver.strain)", ("fem/solver.py", "strain")),
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--material", default="reference")
    ap.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    ap.add_argument("--force", type=float, default=6000.0, help="peak force, N")
    ap.add_argument("--linear-solver", default="fast", choices=["fast", "reference"])
    ap.add_argument("--kinematics", default="small", choices=["small", "finite"])
    ap.add_argument("--mesh-rule", default="yield", choices=["yield", "contact", "contact-dense"])
    ap.add_argument("--load-only", action="store_true", help="0 -> F (no unloading)")
    ap.add_argument("--steps", type=int, default=None, help="load steps per segment")
    ap.add_argument("--solve-steps", type=int, default=None,
                    help="solve only the first N load steps (finite strain, node contact)")
    ap.add_argument("--kernels", default="numpy", choices=["numpy", "compiled"])
    ap.add_argument("--factoriser", default="cholmod", choices=FACTORISERS)
    args = ap.parse_args(argv)
    material = load_material(args.material)
    forces = [0.0, args.force] + ([] if args.load_only else [0.0])
    if args.solve_steps is not None:
        return _profile_steps(args, material, forces)
    profile = cProfile.Profile()
    started = time.perf_counter()
    profile.enable()
    result = run_history(material, forces, mesh=args.mesh, write_fields=False,
                         linear_solver=args.linear_solver, kinematics=args.kinematics,
                         mesh_rule=args.mesh_rule, steps_per_segment=args.steps,
                         step_control="fixed")  # the documented profile's control
    profile.disable()
    wall = time.perf_counter() - started
    stats = pstats.Stats(profile).stats  # {(file, line, name): (cc, nc, tottime, cumtime, ...)}
    s = result.summary
    print(f"{args.mesh} mesh ({args.mesh_rule}), {s['mesh']['elements']} elements, "
          f"{result.solver.ndofs} dofs, {args.kinematics} strain, "
          f"{' -> '.join(f'{f:g}' for f in forces)} N: "
          f"{s['steps']} steps, {s['newton_iterations']} Newton iterations, "
          f"{result.solver.factorisations} factorisations, {wall:.1f} s (under cProfile, "
          f"{args.linear_solver} path; {1e3 * wall / s['newton_iterations']:.0f} ms per "
          "Newton iteration)")
    _print_parts(stats, wall)
    return 0


def _print_parts(stats, wall: float) -> None:
    for label, (suffix, name) in PARTS:
        rows = [(nc, cum) for (file, _, fn), (_, nc, _, cum, _) in stats.items()
                if fn == name and file.replace("\\", "/").endswith(suffix)]
        calls, cumulative = sum(r[0] for r in rows), sum(r[1] for r in rows)
        if calls:
            print(f"  {label:48s} {cumulative:7.2f} s  {100 * cumulative / wall:5.1f} %  "
                  f"({calls} calls)")


def _profile_steps(args, material, forces) -> int:
    """The first ``--solve-steps`` load steps of the run's schedule under cProfile."""
    steps = args.steps or STEPS_PER_SEGMENT[args.mesh]
    fe_mesh = history_mesh(material, max(forces), args.mesh,
                           min_force=smallest_resolved_force(material, forces, steps),
                           rule=args.mesh_rule)
    kwargs = {"force_scale": max(forces), "linear_solver": args.linear_solver}
    solver = (compiled_solver(material, fe_mesh, factoriser=args.factoriser, **kwargs)
              if args.kernels == "compiled" else FiniteStrainSolver(material, fe_mesh, **kwargs))
    targets, _ = load_schedule(forces, steps, float(incipient_yield(material).force))
    state = solver.initial_state()
    profile = cProfile.Profile()
    started, cpu = time.perf_counter(), time.process_time()
    profile.enable()
    iterations = 0
    for step, target in enumerate(targets[1:args.solve_steps + 1], start=1):
        state = _advance(solver, state, target, step)
        iterations += state.iterations
    profile.disable()
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu
    print(f"{args.mesh} mesh ({args.mesh_rule}), {solver.dvolume.shape[0]} elements, "
          f"{solver.ndofs} dofs, finite strain, {args.kernels} kernels"
          f"{', ' + args.factoriser if args.kernels == 'compiled' else ''}: the first "
          f"{args.solve_steps} load steps of {' -> '.join(f'{f:g}' for f in forces)} N "
          f"(to {state.force:.4g} N): {iterations} Newton iterations, "
          f"{solver.factorisations} factorisations, {wall:.1f} s wall, {cpu:.1f} s CPU under "
          f"cProfile: {1e3 * wall / iterations:.0f} ms wall, {1e3 * cpu / iterations:.0f} ms "
          "CPU per Newton iteration")
    _print_parts(pstats.Stats(profile).stats, wall)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
