"""Axisymmetric hemisphere mesh (docs/model.md §5) built with the gmsh Python API.

The model is the quarter disc of the r-z plane with its centre at (0, R): the tip touches the
rigid flat at the origin, the axis is r = 0 and the equatorial (top) face is z = R.

Elements: isoparametric 6-node triangles (quadratic, curved edges on the sphere). Together with
the mean-dilatation B-bar of :mod:`geocontact.fem.solver` (volumetric strain constant per
element, the P2/P0 pair) they do not lock under isochoric plastic flow (beta = 0); see
docs/fem.md.

Element size. As in the paper's model there are three zones of decreasing density away from the
tip (zone I within 0.1 R). Inside zone I the size grows geometrically with the distance d from
the tip, ``h = d / grading``, between a floor ``h_tip = a_min / per_tip_radius`` (a_min is the
smallest contact radius to resolve: ``run.tip_contact_radius``, from the yield contact radius
and the history's first load step) and the zone-I cap; the
whole range of contact radii a_min ... a_max of a history is thus resolved with about
``grading`` elements across each contact radius, at a cost that grows only with log(a_max/a_min).

Resolution of a contact (:func:`elements_across`): the number of surface element edges between
the axis and the contact radius. Measured against Hertz on an elastic grain (docs/fem.md, "Mesh
resolution of the contact"; ``scripts/verify_mesh_resolution.py``): from 2.5 elements on, the
approach is within 0.7 % (plus the finite-size 1 % at the largest loads) and the contact radius
within 2-3.6 %; below, the contact radius error grows to 5.6 % (2-2.5 elements), 9 % (1-1.5)
and 49 % (< 1), the approach error to 1.4 %, 3.6 % and 46 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

# The largest contact radius a run resolves, a fraction of the grain's radius: the refined zone
# of every mesh ends there (build_mesh clips a_max to it), and a run stops at the first recorded
# step whose measured contact radius is larger (fem.run.step_loop: ContactBeyondMeshError).
CONTACT_RADIUS_LIMIT = 0.5


@dataclass(frozen=True)
class MeshPreset:
    """Sizes relative to the resolved contact radii and to the sphere radius R."""

    per_tip_radius: float  # elements across the smallest contact radius
    grading: float  # d / h in zone I: elements across any larger contact radius
    zone_sizes: tuple[float, float, float]  # caps of zones I (d < 0.1R), II (< 0.5R), III, / R


PRESETS = {
    "coarse": MeshPreset(per_tip_radius=3.0, grading=5.0, zone_sizes=(0.02, 0.08, 0.2)),
    "default": MeshPreset(per_tip_radius=5.0, grading=9.0, zone_sizes=(0.01, 0.04, 0.1)),
    "fine": MeshPreset(per_tip_radius=10.0, grading=18.0, zone_sizes=(0.005, 0.02, 0.05)),
}
ZONE_LIMITS = (0.1, 0.5)  # zone I / II / III boundaries as fractions of R (distance from tip)
# Fewest surface elements spanning the contact radius before a run is reported under-resolved:
# the ~2 % accuracy limit measured in docs/fem.md ("Mesh resolution of the contact"). Every
# preset puts per_tip_radius >= 3 elements across the smallest contact radius it is sized for.
MIN_ELEMENTS_ACROSS_CONTACT = 2.5
# Surface elements a history's mesh puts at least across the contact radius of its smallest load
# step (geocontact.fem.run.history_mesh): the threshold above with a margin for gmsh's edge
# lengths (~1 % off the target) and for the run's schedule, whose first steps move with the
# FE-probed first-yield force (a few per cent from the analytic one used for sizing).
ELEMENTS_ACROSS_SMALLEST_CONTACT = 3.0
# Mesh rules (``build_mesh(rule=...)``). "yield": the zones and grading above, the rule every
# verified run was made with. "contact": the same mesh plus a band of small elements along the
# sphere's surface over the contact radii of the plastic range, a_band ... a_max, where the surface
# element edge is d / CONTACT_SURFACE_GRADING[preset] and the size grows with the depth s under
# the surface as ``+ CONTACT_DEPTH_GROWTH * s``: the contact edge moves in steps of a small
# fraction of the contact radius (the loading curve of a weak grain is no longer a staircase,
# docs/fem.md, "The staircase of a growing contact"), at a cost linear in the grading, as only the
# surface layer is refined. "contact-dense": the "contact" rule with CONTACT_DENSE_FACTOR times its
# surface grading (a/120 on the default preset): the bumps the contact edge leaves in a weak
# grain's loading curve shrink with the surface spacing (docs/fem.md, "Where the bumps come from").
MESH_RULES = ("yield", "contact", "contact-dense")
CONTACT_SURFACE_GRADING = {"coarse": 40.0, "default": 60.0, "fine": 100.0}
CONTACT_DENSE_FACTOR = 2.0
CONTACT_DEPTH_GROWTH = 0.3


def mesh_preset(name: str) -> MeshPreset:
    if name not in PRESETS:
        raise InputError(f"mesh: unknown preset {name!r} (allowed: {', '.join(PRESETS)})")
    return PRESETS[name]


def element_size(d: np.ndarray | float, radius: float, a_min: float, a_max: float,
                 preset: MeshPreset, *, depth: np.ndarray | float = 0.0,
                 band: tuple[float, float] | None = None) -> np.ndarray | float:
    """Target element size at distance d from the tip (``depth``: under the sphere's surface).

    ``band`` (a_band, surface grading): the "contact" rule's surface band (``MESH_RULES``).
    """
    h_tip = a_min / preset.per_tip_radius
    caps = [s * radius for s in preset.zone_sizes]
    cap = np.where(d < ZONE_LIMITS[0] * radius, caps[0],
                   np.where(d < ZONE_LIMITS[1] * radius, caps[1], caps[2]))
    # Past the largest contact radius the grading may relax twice as fast.
    graded = np.where(d <= a_max, d / preset.grading,
                      a_max / preset.grading + 2.0 * (d - a_max) / preset.grading)
    h = np.maximum(h_tip, np.minimum(graded, cap))
    if band is None:
        return h
    a_band, surface_grading = band
    along = np.where(d <= a_max, np.maximum(d, a_band),
                     a_max + 2.0 * (d - a_max)) / surface_grading
    return np.minimum(h, np.maximum(along + CONTACT_DEPTH_GROWTH * depth, h_tip))


def _restore_signal_handlers() -> None:
    """gmsh's initialisation installs C-level handlers for SIGTERM and others that end the
    process at once; put Python's back so that a SIGTERM ends a run as cleanly as Ctrl-C
    (checkpoint kept, temporaries removed, exit code 143 from the CLI)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return
    for number in (signal.SIGTERM, signal.SIGINT):
        handler = signal.getsignal(number)
        if handler is not None:
            signal.signal(number, handler)


def surface_vertex_radii(mesh, radius: float) -> np.ndarray:
    """Radii r of the element vertices on the sphere of radius ``radius`` (ascending; the tip,
    r = 0, first): the ends of the surface element edges. Mid-edge nodes are left out."""
    vertices = np.unique(mesh.t[:3])
    r, z = mesh.doflocs[:, vertices]
    on = np.abs(np.hypot(r, z - radius) - radius) < 1e-7 * radius
    return np.sort(r[on])


def elements_across(mesh, radius: float, contact_radius) -> float | np.ndarray:
    """Surface elements spanning the contact radius: the number of surface element edges between
    the axis and r = ``contact_radius``, the edge cut by the contact circle counted by the
    fraction of it inside. ``radius``: the sphere's."""
    ends = surface_vertex_radii(mesh, radius)
    inner, outer = ends[:-1], ends[1:]
    a = np.asarray(contact_radius, dtype=float)
    inside = np.clip((a[..., None] - inner) / (outer - inner), 0.0, 1.0)
    count = np.sum(inside, axis=-1)
    return float(count) if np.ndim(contact_radius) == 0 else count


def build_mesh(radius: float, a_min: float, a_max: float, preset: str | MeshPreset = "default",
               *, rule: str = "yield", a_band: float | None = None):
    """gmsh mesh of the hemisphere, returned as an isoparametric ``skfem.MeshTri2``.

    ``a_min`` / ``a_max``: the smallest and largest contact radius the run must resolve (m).
    ``rule``: "yield" (default), "contact" or "contact-dense" (``MESH_RULES``), whose surface
    band starts at the contact radius ``a_band`` (default ``a_min``; needs a named preset).
    """
    import gmsh
    from skfem import MeshTri2

    p = mesh_preset(preset) if isinstance(preset, str) else preset
    if not (0 < a_min <= a_max):
        raise InputError(f"mesh: need 0 < a_min <= a_max, got {a_min:g}, {a_max:g}")
    if rule not in MESH_RULES:
        raise InputError(f"mesh_rule: unknown {rule!r} (allowed: {', '.join(MESH_RULES)})")
    a_max = min(a_max, CONTACT_RADIUS_LIMIT * radius)
    a_min = min(a_min, a_max)
    band = None
    if rule != "yield":
        if not isinstance(preset, str):
            raise InputError(f"mesh: the {rule} rule needs a named preset")
        grading = CONTACT_SURFACE_GRADING[preset] * (
            CONTACT_DENSE_FACTOR if rule == "contact-dense" else 1.0)
        band = (min(a_band or a_min, a_max), grading)

    owns = not gmsh.isInitialized()
    if owns:
        gmsh.initialize(interruptible=False)
        _restore_signal_handlers()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("hemisphere")
        geo = gmsh.model.geo
        tip = geo.addPoint(0.0, 0.0, 0.0)
        centre = geo.addPoint(0.0, radius, 0.0)
        rim = geo.addPoint(radius, radius, 0.0)
        surface = geo.addCircleArc(tip, centre, rim)
        top = geo.addLine(rim, centre)
        axis = geo.addLine(centre, tip)
        loop = geo.addCurveLoop([surface, top, axis])
        geo.addPlaneSurface([loop])
        geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
        gmsh.option.setNumber("Mesh.ElementOrder", 2)
        gmsh.option.setNumber("Mesh.HighOrderOptimize", 0)

        def size(dim, tag, x, y, z, lc):
            depth = max(radius - math.hypot(x, y - radius), 0.0)
            return float(element_size(math.hypot(x, y), radius, a_min, a_max, p, depth=depth,
                                      band=band))

        gmsh.model.mesh.setSizeCallback(size)
        gmsh.model.mesh.generate(2)
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        elem_types, _, elem_nodes = gmsh.model.mesh.getElements(2)
        tri6 = [i for i, t in enumerate(elem_types) if t == 9]
        if not tri6:
            raise RuntimeError("gmsh produced no 6-node triangles")
        conn = np.asarray(elem_nodes[tri6[0]], dtype=np.int64).reshape(-1, 6)
    finally:
        gmsh.model.remove()
        if owns:
            gmsh.finalize()

    xyz = np.asarray(coords).reshape(-1, 3)[:, :2]
    index = np.zeros(int(np.max(node_tags)) + 1, dtype=np.int64)
    index[np.asarray(node_tags, dtype=np.int64)] = np.arange(len(node_tags))
    conn = index[conn]
    # Orient counter-clockwise; gmsh's triangle6 order (vertices, then edges 0-1, 1-2, 2-0) is
    # the one skfem's MeshTri2 expects in its extra rows of t.
    e1 = xyz[conn[:, 1]] - xyz[conn[:, 0]]
    e2 = xyz[conn[:, 2]] - xyz[conn[:, 0]]
    flip = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    conn[flip] = conn[flip][:, [0, 2, 1, 5, 4, 3]]
    used = np.unique(conn)
    renumber = np.full(len(xyz), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    return MeshTri2(np.ascontiguousarray(xyz[used].T), np.ascontiguousarray(renumber[conn].T))
