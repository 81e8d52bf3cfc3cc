"""Where an FE run's time goes (issue 12): the reference cycle 0 -> F -> 0 under cProfile, with
the time of the sparse factorisation, the element kernels (assembly of stiffness and internal
force), the return mapping and the triangular solves, and the run's steps, Newton iterations
and linear solves.

    PYTHONPATH=src .venv/bin/python scripts/profile_fe.py [--mesh default] [--force 6000]
        [--linear-solver fast|reference]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

from geocontact.fem.run import run_history
from geocontact.grain.material import load_material

# (label, where the time is spent: a pstats function key's file suffix and function name)
PARTS = (
    ("sparse LU factorisation (SuperLU gstrf)", ("~", "<built-in method scipy.sparse.linalg."
                                                 "_dsolve._superlu.gstrf>")),
    ("triangular solves (SuperLU solve)", ("~", "<method 'solve' of 'SuperLU' objects>")),
    ("tangent stiffness assembly (solver.stiffness)", ("fem/solver.py", "stiffness")),
    ("fast path: factorisation (solver.factorise)", ("fem/solver.py", "factorise")),
    ("fast path: element matrices (solver.element_matrices)", ("fem/solver.py",
                                                              "element_matrices")),
    ("fast path: bordered system (solver._bordered_system)", ("fem/solver.py",
                                                             "_bordered_system")),
    ("internal force (solver.internal_force)", ("fem/solver.py", "internal_force")),
    ("strains (solver.strain)", ("fem/solver.py", "strain")),
    ("return mapping (plasticity.return_mapping)", ("fem/plasticity.py", "return_mapping")),
    ("contact forces (solver.contact_forces)", ("fem/solver.py", "contact_forces")),
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--material", default="reference")
    ap.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    ap.add_argument("--force", type=float, default=6000.0, help="peak force, N")
    ap.add_argument("--linear-solver", default="fast", choices=["fast", "reference"])
    args = ap.parse_args(argv)
    material = load_material(args.material)
    profile = cProfile.Profile()
    started = time.perf_counter()
    profile.enable()
    result = run_history(material, [0.0, args.force, 0.0], mesh=args.mesh, write_fields=False,
                         linear_solver=args.linear_solver)
    profile.disable()
    wall = time.perf_counter() - started
    stats = pstats.Stats(profile).stats  # {(file, line, name): (cc, nc, tottime, cumtime, ...)}
    s = result.summary
    print(f"{args.mesh} mesh, {s['mesh']['elements']} elements, 0 -> {args.force:g} -> 0 N: "
          f"{s['steps']} steps, {s['newton_iterations']} Newton iterations, "
          f"{result.solver.factorisations} factorisations, {wall:.1f} s (under cProfile, "
          f"{args.linear_solver} path)")
    for label, (suffix, name) in PARTS:
        rows = [(nc, cum) for (file, _, fn), (_, nc, _, cum, _) in stats.items()
                if fn == name and file.replace("\\", "/").endswith(suffix)]
        calls, cumulative = sum(r[0] for r in rows), sum(r[1] for r in rows)
        print(f"  {label:48s} {cumulative:7.2f} s  {100 * cumulative / wall:5.1f} %  "
              f"({calls} calls)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
