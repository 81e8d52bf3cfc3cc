"""The same sphere / rigid-flat problem in CalculiX (``ccx``), the peer FE code.

Used to check ``geocontact.fem`` against an independent implementation and to time it against
one (benchmarks/bench_ccx.py, docs/fem.md "Peer code: CalculiX"). The model is ours as far as
CalculiX allows:

- the very same gmsh mesh (``run.history_mesh``): our 6-node triangles become CAX6 elements
  (CalculiX expands them into 15-node wedges of a 2 degree sector, full integration, no B-bar);
- von Mises / Drucker-Prager is not available as such: the material must be beta = 0 and is
  written as ``*ELASTIC`` + ``*PLASTIC`` (isotropic hardening table; perfectly plastic when
  the hardening ratio is 0); small strain by default, geometrically nonlinear with
  ``nlgeom=True`` (``*STEP, NLGEOM``: the peer of ``kinematics="finite"``);
- the rigid frictionless flat is a block of elements below z = 0 whose nodes are all fixed; its
  top edge is the master surface, the sphere's edges (z0 < 0.3 R, as in our model) the slave
  surface of a face-to-face *penalty* contact (``PRESSURE-OVERCLOSURE=LINEAR``, no friction).
  CalculiX has no exact unilateral constraint for this case; the penalty slope is
  ``penalty x E / h_tip`` (h_tip the smallest element size) and its effect is measured by the
  benchmark;
- the top face is displacement-controlled: every top node gets u_z = -w (free in r) and the
  force is the sum of their reactions (printed by CalculiX for its 2 degree sector, x 180).
  Force control is not possible: at F = 0 the penalty contact carries no stiffness and the
  body is free. The residual approach is therefore where the unloading
  force reaches zero, from a power-law fit F = C (delta - delta_res)^n to the last three
  loaded points.

Approaches are ball-ball (2 x the interference of the half model), as everywhere (docs/model.md §2).
"""

from __future__ import annotations

import os
import re
import resource
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConvergenceError, InputError
from ..grain.material import Material

PAIR = 2.0  # ball-ball approach = 2 x the half model's interference (docs/model.md §2)
CONTACT_ZONE = 0.3  # slave surface: sphere edges with z0 < 0.3 R (as solver.py's contact nodes)
PENALTY_DEFAULT = 100.0  # contact slope = PENALTY_DEFAULT x E / h_tip
# CalculiX expands axisymmetric elements into a 2 degree sector; the force totals it prints are
# for that sector (measured: x 180 the elastic force matches Hertz to 0.5 %, coarse mesh).
SECTORS = 180.0


@dataclass(frozen=True)
class AxisymmetricMesh:
    """Nodes (r, z) and 6-node triangles (vertices counter-clockwise, then the mid-edge nodes of
    edges 1-2, 2-3, 3-1: the node order of both gmsh's triangle6 and CalculiX's CAX6)."""

    points: np.ndarray  # (n, 2)
    triangles: np.ndarray  # (m, 6), 0-based

    @classmethod
    def from_skfem(cls, mesh) -> AxisymmetricMesh:
        """From the ``skfem.MeshTri2`` of ``mesh.build_mesh`` (points: vertices, then one mid-edge
        node per facet; skfem's t2f rows are the edges 0-1, 1-2, 0-2)."""
        triangles = np.vstack([mesh.t, mesh.t2f + mesh.t.max() + 1]).T
        return cls(np.ascontiguousarray(mesh.doflocs.T), np.ascontiguousarray(triangles))

    def smallest_edge(self) -> float:
        p = self.points[self.triangles[:, :3]]
        return float(np.min(np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2)))


def sphere_faces(mesh: AxisymmetricMesh, radius: float, zone: float = CONTACT_ZONE
                 ) -> list[tuple[int, int]]:
    """(element, face 1..3) of the element edges on the sphere below z = zone x R."""
    on_sphere = np.abs(np.hypot(mesh.points[:, 0], mesh.points[:, 1] - radius) - radius) \
        < 1e-9 * radius
    low = mesh.points[:, 1] < zone * radius
    faces = []
    for face, (a, b, mid) in enumerate(((0, 1, 3), (1, 2, 4), (2, 0, 5)), start=1):
        nodes = mesh.triangles[:, [a, b, mid]]
        hit = np.all(on_sphere[nodes], axis=1) & np.all(low[nodes], axis=1)
        faces += [(int(e), face) for e in np.nonzero(hit)[0]]
    return sorted(faces)


def _num(x: float) -> str:
    """A float as CalculiX reads it: at most 20 characters per field, so 13 digits."""
    return f"{float(x):.12e}"


def _lines(values, per_line: int = 8) -> list[str]:
    values = list(values)
    return [", ".join(str(v) for v in values[i:i + per_line])
            for i in range(0, len(values), per_line)]


def write_deck(path: str | Path, material: Material, mesh: AxisymmetricMesh,
               interferences: list[float], increments: list[int], *,
               penalty: float = PENALTY_DEFAULT,
               residual_tolerance: float | None = None,
               nlgeom: bool = False) -> dict[str, Any]:
    """Write the CalculiX input deck; returns what it chose (penalty slope, node/element counts).

    ``interferences``: top-face displacement waypoints w >= 0 of the half model (m), one
    *STEP per waypoint, the first starting from w = 0; ``increments``: the largest number of
    increments per step (CalculiX may cut back, never coarsen beyond it).
    ``residual_tolerance``: the largest residual / average nodal force accepted (CalculiX's
    R_n, and R_p after 9 iterations; None keeps its defaults, 0.005 and 0.02).
    ``nlgeom``: geometrically nonlinear steps (``*STEP, NLGEOM``; CalculiX's *PLASTIC then
    works on the multiplicative decomposition of the deformation gradient), the peer of our
    ``kinematics="finite"``; False: small strain, the peer of ``kinematics="small"``.
    """
    if material.friction_angle_deg != 0.0:
        raise InputError("ccx: CalculiX's *PLASTIC is von Mises; need friction_angle_deg = 0, "
                         f"got {material.friction_angle_deg:g}")
    if len(increments) != len(interferences) or min(increments, default=1) < 1:
        raise InputError("ccx: need one increment count >= 1 per waypoint")
    if any(w < 0 for w in interferences):
        raise InputError("ccx: interferences must be >= 0 (m)")
    radius = material.radius
    points, tri = mesh.points, mesh.triangles
    n = len(points)
    h_tip = mesh.smallest_edge()
    slope = penalty * material.youngs_modulus / h_tip
    top = np.nonzero(np.abs(points[:, 1] - radius) < 1e-9 * radius)[0]
    axis = np.nonzero(np.abs(points[:, 0]) < 1e-12 * radius)[0]
    faces = sphere_faces(mesh, radius)
    if not faces or len(top) == 0 or len(axis) == 0:
        raise InputError("ccx: mesh has no contact surface, top face or axis nodes")

    # Rigid flat: one 4-node element under the contact zone, every node fixed. Its top edge
    # starts just off the axis: CalculiX cannot take normals on master edges with axis nodes.
    reach = 1.5 * np.max(points[np.unique(tri[[e for e, _ in faces]]), 0])
    r0 = 1e-3 * h_tip
    flat = n + np.arange(4)
    flat_xy = [(r0, -reach), (reach, -reach), (reach, 0.0), (r0, 0.0)]
    eflat = len(tri) + 1

    hardening = material.hardening_modulus
    lines = ["** geocontact.verification.ccx: hemisphere on a rigid frictionless flat "
             "(axisymmetric)",
             "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {_num(x)}, {_num(y)}" for i, (x, y) in enumerate(points)]
    lines += [f"{k + 1}, {_num(x)}, {_num(y)}" for k, (x, y) in zip(flat, flat_xy, strict=True)]
    lines += ["*ELEMENT, TYPE=CAX6, ELSET=SPHERE"]
    lines += [f"{e + 1}, " + ", ".join(str(int(v) + 1) for v in row) for e, row in enumerate(tri)]
    lines += ["*ELEMENT, TYPE=CAX4, ELSET=FLAT", f"{eflat}, " + ", ".join(str(k + 1) for k in flat)]
    lines += ["*NSET, NSET=TOP"] + _lines(top + 1)
    lines += ["*NSET, NSET=AXIS"] + _lines(axis + 1)
    lines += ["*NSET, NSET=FLATNODES"] + _lines(flat + 1)
    lines += ["*SURFACE, NAME=SPHERESURF, TYPE=ELEMENT"]
    lines += [f"{e + 1}, S{f}" for e, f in faces]
    lines += ["*SURFACE, NAME=FLATSURF, TYPE=ELEMENT", f"{eflat}, S3"]
    lines += [
        "*MATERIAL, NAME=SPHEREMAT",
        "*ELASTIC",
        f"{_num(material.youngs_modulus)}, {_num(material.poissons_ratio)}",
        "*PLASTIC",
        f"{_num(material.compressive_yield_stress)}, 0.0",
    ]
    if hardening > 0:
        # linear isotropic hardening: sigma_y = sigma_c + H eps_p, tabulated to eps_p = 1
        lines += [f"{_num(material.compressive_yield_stress + hardening)}, 1.0"]
    lines += [
        "*MATERIAL, NAME=FLATMAT", "*ELASTIC", f"{_num(material.youngs_modulus)}, 0.3",
        "*SOLID SECTION, ELSET=SPHERE, MATERIAL=SPHEREMAT",
        "*SOLID SECTION, ELSET=FLAT, MATERIAL=FLATMAT",
        "*SURFACE INTERACTION, NAME=FRICTIONLESS",
        "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
        f"{_num(slope)}",
        "*CONTACT PAIR, INTERACTION=FRICTIONLESS, TYPE=SURFACE TO SURFACE",
        "SPHERESURF, FLATSURF",
        "*BOUNDARY", "AXIS, 1, 1", "FLATNODES, 1, 2",
    ]
    for w, count in zip(interferences, increments, strict=True):
        dt = 1.0 / count
        lines += [
            "*STEP, NLGEOM, INC=100000" if nlgeom else "*STEP, INC=100000",
            "*STATIC",
            f"{_num(dt)}, 1.0, {_num(dt * 1e-3)}, {_num(dt)}",
        ]
        if residual_tolerance is not None:
            tol = _num(residual_tolerance)
            lines += ["*CONTROLS, PARAMETERS=FIELD", f"{tol}, , , , {tol}"]
        lines += [
            "*BOUNDARY", f"TOP, 2, 2, {_num(-w)}",
            "*NODE PRINT, NSET=TOP, TOTALS=ONLY",
            "RF",
            "*END STEP",
        ]
    Path(path).write_text("\n".join(lines) + "\n")
    return {"penalty_factor": penalty, "penalty_slope_Pa_per_m": slope, "smallest_edge_m": h_tip,
            "elements": int(len(tri)), "nodes": int(n), "contact_faces": len(faces)}


_TOTAL = re.compile(r"total force \(fx,fy,fz\) for set TOP and time\s+(\S+)", re.IGNORECASE)


def read_dat(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(total time, axial force on the top face) of every increment in the .dat file.

    The force is the total over the top nodes (``*NODE PRINT, TOTALS=ONLY``), scaled from
    CalculiX's 2 degree sector to the whole circumference; positive in compression.
    """
    times, forces = [], []
    lines = Path(path).read_text().splitlines()
    for i, line in enumerate(lines):
        m = _TOTAL.search(line)
        if m:
            values = next(v for v in lines[i + 1:] if v.strip()).split()
            times.append(float(m.group(1)))
            forces.append(float(values[1]))
    return np.array(times), -SECTORS * np.array(forces)


def interference_path(times: np.ndarray, interferences: list[float]) -> np.ndarray:
    """Top displacement at each total time: step k (time k-1 .. k) ramps linearly from
    waypoint k-1 (0 before the first) to waypoint k."""
    knots = np.concatenate([[0.0], interferences])
    return np.interp(times, np.arange(len(knots), dtype=float), knots)


def residual_approach(approach: np.ndarray, force: np.ndarray, zero: float) -> float | None:
    """Approach at which the unloading branch (approach decreasing) reaches F = 0.

    The last three points with F > zero are fitted with F = C (delta - delta_res)^n (the
    unloading of a sphere is a power law, n near 3/2), which is exact for such a curve;
    linear interpolation to the first zero point if the fit has no root in range.
    """
    loaded = np.nonzero(force > zero)[0]
    if len(loaded) == 0 or loaded[-1] == len(force) - 1:
        return None  # never loaded, or still in contact at the end
    k = loaded[-1]
    d_zero = approach[k + 1]  # contact lost between points k and k + 1
    linear = d_zero
    if k >= 1 and force[k - 1] > force[k]:
        slope = (force[k - 1] - force[k]) / (approach[k - 1] - approach[k])
        linear = max(d_zero, approach[k] - force[k] / slope)
    if k >= 2 and np.all(np.diff(approach[k - 2:k + 1]) < 0):
        from scipy.optimize import brentq

        d = approach[k - 2:k + 1]
        f = force[k - 2:k + 1]

        def mismatch(dr):
            return (np.log(f[0] / f[1]) * np.log((d[1] - dr) / (d[2] - dr))
                    - np.log(f[1] / f[2]) * np.log((d[0] - dr) / (d[1] - dr)))

        lo, hi = d_zero, d[2] * (1 - 1e-12)
        try:
            if mismatch(lo) * mismatch(hi) < 0:
                return float(brentq(mismatch, lo, hi, xtol=1e-15 * d[0]))
        except ValueError:
            pass
    return float(linear)


def branches(approach: np.ndarray, force: np.ndarray
             ) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """(approach, force) of the loading branch (up to the largest force) and of the unloading
    branch while in contact (force > 1e-6 of its start), each sorted by increasing approach."""
    k = int(np.argmax(force))
    load = (approach[:k + 1], force[:k + 1])
    a, f = approach[k:], force[k:]
    keep = f > 1e-6 * f[0]
    return load, (a[keep][::-1], f[keep][::-1])


def force_difference(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                     scale: float) -> dict[str, float | None]:
    """Largest |F_a - F_b| at equal approach / ``scale`` per branch ("loading", "unloading")
    of two load-unload curves (approach, force), over the approaches both branches cover (b
    interpolated at a's points); None where they share none."""
    out: dict[str, float | None] = {}
    for name, (da, fa), (db, fb) in zip(("loading", "unloading"), branches(*a), branches(*b),
                                        strict=True):
        lo, hi = max(da[0], db[0]), min(da[-1], db[-1])
        inside = (da >= lo) & (da <= hi)
        diff = np.abs(fa[inside] - np.interp(da[inside], db, fb))
        out[name] = float(np.max(diff) / scale) if diff.size else None
    return out


# --- comparing load-unload curves (``run``: a dict with "approach", "force" arrays and the
# cycle's "max_approach_m", "residual_approach_m", "max_force_N") -----------------------------
def loading_force_at(run: dict, approaches) -> np.ndarray:
    """The loading force at each approach (linear between the run's points; NaN beyond)."""
    (d, f), _ = branches(run["approach"], run["force"])
    return np.interp(approaches, d, f, right=np.nan)


def loading_approach_at(run: dict, forces) -> np.ndarray:
    """The loading approach at each force: the inverse of ``loading_force_at`` on the running
    maximum of the force (a displacement-controlled run's force can dip as a node engages;
    the first approach that reaches the force counts); NaN beyond the largest loading force."""
    (d, f), _ = branches(run["approach"], run["force"])
    top = np.maximum.accumulate(f)
    out = []
    for x in np.atleast_1d(forces):
        if x > top[-1] * (1 + 1e-12) or x < 0:
            out.append(np.nan)
            continue
        k = int(np.searchsorted(top, x))  # first point with running maximum >= x
        if k == 0:
            out.append(float(d[0]))
            continue
        lo, hi = f[k - 1], f[k]  # f[k] = top[k] >= x > top[k - 1] >= f[k - 1]
        t = (x - lo) / (hi - lo)
        out.append(float(d[k - 1] + t * (d[k] - d[k - 1])))
    return np.array(out)


def elastic_recovery(run: dict) -> float:
    """Largest minus residual approach of one load-unload cycle (m)."""
    return float(run["max_approach_m"] - run["residual_approach_m"])


def smoothed_force_at(run: dict, approaches, window: float = 0.2) -> np.ndarray:
    """The loading force at each approach d from a power law F = C x^b fitted (least squares in
    log-log) to the loading points within (1 -/+ window) d: the force without the step-to-step
    scatter of a contact edge crossing element nodes (both codes show it); NaN where fewer than
    three points fall in the window."""
    (d, f), _ = branches(run["approach"], run["force"])
    out = []
    for x in np.atleast_1d(approaches):
        keep = (d >= (1 - window) * x) & (d <= (1 + window) * x) & (f > 0)
        if np.count_nonzero(keep) < 3 or x > d[-1] * (1 + 1e-9):
            out.append(np.nan)
            continue
        slope, offset = np.polyfit(np.log(d[keep]), np.log(f[keep]), 1)
        out.append(float(np.exp(offset + slope * np.log(x))))
    return np.array(out)


def loading_work_at(run: dict, approaches) -> np.ndarray:
    """The work of the loading force from 0 to each approach (trapezoids on the run's points,
    the last one cut at the approach): an integral measure, insensitive to the scatter."""
    (d, f), _ = branches(run["approach"], run["force"])
    work = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(d))])
    out = []
    for x in np.atleast_1d(approaches):
        if x > d[-1] * (1 + 1e-9):
            out.append(np.nan)
            continue
        k = int(np.searchsorted(d, x))
        fx = np.interp(x, d, f)
        out.append(float(work[k - 1] + 0.5 * (f[k - 1] + fx) * (x - d[k - 1])) if k else 0.0)
    return np.array(out)


def unloading_shape(run: dict, t: np.ndarray) -> np.ndarray:
    """P/P_max of the unloading branch at t = (d - d_res)/(d_max - d_res): its shape, free of
    the peak force and residual approach."""
    _, (d, f) = branches(run["approach"], run["force"])
    d = np.concatenate([[run["residual_approach_m"]], d])
    f = np.concatenate([[0.0], f])
    tt = (d - run["residual_approach_m"]) / (run["max_approach_m"] - run["residual_approach_m"])
    return np.interp(t, tt, f / run["max_force_N"])


def unloading_exponent(run: dict) -> float:
    """n of P/P_max = t^n, t = (d - d_res)/(d_max - d_res): least squares in log space over the
    unloading points with 2 % < P/P_max < 98 % (as docs/verification.md item 11)."""
    _, (d, f) = branches(run["approach"], run["force"])
    t = (d - run["residual_approach_m"]) / (run["max_approach_m"] - run["residual_approach_m"])
    p = f / run["max_force_N"]
    keep = (p > 0.02) & (p < 0.98) & (t > 0)
    return float(np.sum(np.log(t[keep]) * np.log(p[keep])) / np.sum(np.log(t[keep]) ** 2))


@dataclass
class CcxResult:
    curve: dict[str, np.ndarray]  # time, approach_m (pair), force_N
    summary: dict[str, Any]
    workdir: Path | None = field(default=None, repr=False)


def _children_cpu() -> float:
    """User + system CPU time of this process's finished children (s)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def ccx_executable() -> str | None:
    return shutil.which("ccx")


def ccx_version() -> str | None:
    """The version CalculiX prints (``ccx -v``: "This is Version 2.20"), None if not on PATH."""
    exe = ccx_executable()
    if exe is None:
        return None
    proc = subprocess.run([exe, "-v"], capture_output=True, text=True)
    m = re.search(r"Version\s+(\S+)", proc.stdout + proc.stderr)
    return m.group(1) if m else "unknown"


def run_ccx(material: Material, mesh: AxisymmetricMesh, approaches: list[float],
            increments: list[int], *, penalty: float = PENALTY_DEFAULT,
            residual_tolerance: float | None = None, threads: int = 1,
            workdir: str | Path | None = None, nlgeom: bool = False) -> CcxResult:
    """Run CalculiX through the approach (ball-ball) waypoints ``approaches`` (loading and
    unloading steps); wall and CPU time are those of the ``ccx`` process alone. A run that
    stops early raises ConvergenceError whose ``partial`` holds the increments that converged
    (time, approach_m, force_N, wall_time_s, cpu_time_s). ``nlgeom``:
    geometrically nonlinear (``write_deck``)."""
    exe = ccx_executable()
    if exe is None:
        raise InputError("ccx: the CalculiX executable 'ccx' is not on PATH "
                         "(Debian/Ubuntu: apt-get install calculix-ccx)")
    interferences = [a / PAIR for a in approaches]
    own = workdir is None
    work = Path(tempfile.mkdtemp(prefix="geocontact-ccx-")) if own else Path(workdir)
    work.mkdir(parents=True, exist_ok=True)
    try:
        info = write_deck(work / "sphere.inp", material, mesh, interferences, increments,
                          penalty=penalty, residual_tolerance=residual_tolerance,
                          nlgeom=nlgeom)
        env = dict(os.environ, OMP_NUM_THREADS=str(threads),
                   CCX_NPROC_EQUATION_SOLVER=str(threads), CCX_NPROC_RESULTS=str(threads),
                   CCX_NPROC_STIFFNESS=str(threads))
        cpu_before = _children_cpu()
        started = time.perf_counter()
        proc = subprocess.run([exe, "-i", "sphere"], cwd=work, env=env, capture_output=True,
                              text=True)
        wall = time.perf_counter() - started
        cpu = _children_cpu() - cpu_before
        (work / "ccx.log").write_text(proc.stdout + proc.stderr)
        times, force = read_dat(work / "sphere.dat")
        if proc.returncode != 0 or "*ERROR" in proc.stdout or len(times) == 0 or \
                times[-1] < len(approaches) - 1e-9:
            tail = " ".join((proc.stdout + proc.stderr).strip().splitlines()[-3:])
            error = ConvergenceError(f"ccx: run stopped at total time "
                                     f"{times[-1] if len(times) else 0:g} of "
                                     f"{len(approaches)}: {tail}")
            # the increments that did converge: time, approach_m (pair), force_N from 0
            t = np.concatenate([[0.0], times])
            error.partial = {"time": t,
                             "approach_m": PAIR * interference_path(t, interferences),
                             "force_N": np.concatenate([[0.0], force]),
                             "wall_time_s": wall, "cpu_time_s": cpu}
            raise error
        times = np.concatenate([[0.0], times])
        force = np.concatenate([[0.0], force])
        approach = PAIR * interference_path(times, interferences)
        fmax = float(np.max(force))
        k = int(np.argmax(force))
        summary = {
            "wall_time_s": wall,
            "cpu_time_s": cpu,
            "increments": int(len(times) - 1),
            "max_force_N": fmax,
            "max_approach_m": float(approach[k]),
            "residual_approach_m": residual_approach(approach[k:], force[k:], 1e-6 * fmax),
            "mesh": {"elements": info["elements"], "nodes": info["nodes"],
                     "element": "CAX6 (15-node wedge of a 2 degree sector, full integration)"},
            "contact": {"type": "face-to-face penalty, frictionless",
                        "penalty_factor": penalty,
                        "penalty_slope_Pa_per_m": info["penalty_slope_Pa_per_m"],
                        "smallest_edge_m": info["smallest_edge_m"],
                        "slave_faces": info["contact_faces"]},
            "residual_tolerance": residual_tolerance,
            "kinematics": "finite (NLGEOM)" if nlgeom else "small",
            "threads": threads,
            "ccx": exe,
        }
        return CcxResult({"time": times, "approach_m": approach, "force_N": force}, summary,
                         None if own else work)
    finally:
        if own:
            shutil.rmtree(work, ignore_errors=True)


__all__ = ["AxisymmetricMesh", "CcxResult", "branches", "ccx_executable", "ccx_version",
           "elastic_recovery", "force_difference", "loading_approach_at", "loading_force_at",
           "loading_work_at", "read_dat", "residual_approach", "run_ccx", "smoothed_force_at",
           "sphere_faces", "unloading_exponent", "unloading_shape", "write_deck"]
