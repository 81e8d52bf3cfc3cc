"""The dent a plastic contact leaves on a grain, measured on the FE's residual surface, and what a
new contact beside it would meet (docs/dem.md, "FE check of the 2 a_max rule").

The LAMMPS plugin's ``memory place`` forgets a contact's dent once the contact point has moved
over either grain's surface by more than ``DENT_TRAVEL_FACTOR`` x a_max (a_max: the contact
radius at the top of the contact's envelope). A new contact circle of radius a_max centred at a
distance s from the old one covers the surface from s - a_max to s + a_max; it misses a dent of
extent e once s > e + a_max. The rule's factor 2 is right when the dent ends near a_max.

The FE model is one grain of the pair pressed on a rigid frictionless flat (ball-wall; the flat
is the symmetry plane of two equal grains), so its residual surface is one grain's dent. The
dent depth at a surface point is how far the surface lies behind the undeformed sphere moved
rigidly with the grain's centre (the equatorial face, which moves down by the ball-wall approach
w): D = z0 + u_z - (R - sqrt(R^2 - rho^2)) + w at the point's radius rho (the FE's own:
reference radius in small strain, current radius in finite strain). At the tip D is the
residual ball-wall approach, the law's residual approach per grain.

What a new contact of radius a at offset s meets, to first order in the dent: an extra gap
g(x) = D(|x|) under it changes its force at a fixed approach by -k_n times the mean of g with
the weight of a rigid flat punch, (a^2 - t^2)^(-1/2) at a distance t from its centre
(Betti's reciprocity: the pressure of a unit punch displacement over the contact disc is
E*/(pi sqrt(a^2 - t^2)), whose integral is the normal stiffness k_n = 2 E* a; Johnson,
*Contact Mechanics*, 1985, §3.8 and §5.1). So that weighted mean, ``punch_mean``, is the
change of approach the new contact feels from the dent: the dent's share of a new contact's
law.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# The plugin's threshold in dent radii (plugins/lammps/src/contact_forces.h, kDentTravelRadii):
# the contact point must travel DENT_TRAVEL_FACTOR x a_max before the dent is forgotten.
DENT_TRAVEL_FACTOR = 2.0
# Gauss points across the new contact disc (polar angle of the punch substitution t = a sin phi)
# and points round it: ample for a profile resolved by the FE's surface nodes.
PUNCH_RADIAL_POINTS = 24
PUNCH_ANGULAR_POINTS = 96


@dataclass(frozen=True)
class ResidualDent:
    """A grain's residual surface after loading to F_max and unloading to 0 (one grain)."""

    radius_m: np.ndarray  # surface nodes' radii (ascending; the FE's radius of each node)
    depth_m: np.ndarray  # dent depth D at each node (m; > 0: the surface lies behind the sphere)
    contact_radius_m: float  # a_max, the FE's contact radius at F_max
    residual_approach_m: float  # the ball-wall residual approach w_res (the equator's motion)

    @property
    def centre_depth_m(self) -> float:
        return float(self.depth_m[0])

    def depth_at(self, radius) -> np.ndarray:
        """D at the radii ``radius`` (m), linear between the nodes, 0 beyond the last one."""
        return np.interp(radius, self.radius_m, self.depth_m, right=0.0)


def residual_dent(solver, state, contact_radius: float) -> ResidualDent:
    """The dent of the FE state ``state`` (unloaded: force 0) of ``solver`` (fem.solver's
    ContactSolver or a subclass) whose peak contact radius was ``contact_radius``."""
    if state.force != 0.0:
        raise ValueError(f"residual_dent: the state must be unloaded, got F = {state.force:g} N")
    R = solver.material.radius
    rho = np.asarray(solver.candidate_radii(state), dtype=float)
    uz = state.displacement[solver.candidate_dofs]
    sphere = R - np.sqrt(np.maximum(R * R - rho * rho, 0.0))
    depth = solver.candidate_z0 + uz - sphere + state.top_displacement
    order = np.argsort(rho)
    return ResidualDent(rho[order], depth[order], float(contact_radius),
                        float(state.top_displacement))


def extent(dent: ResidualDent, fraction: float) -> float:
    """The outermost radius where |D| is still ``fraction`` of the centre depth (m): past it
    the dent is smaller than that fraction everywhere, pile-up included."""
    deep = np.nonzero(np.abs(dent.depth_m) >= fraction * abs(dent.centre_depth_m))[0]
    k = int(deep[-1])
    if k + 1 >= len(dent.radius_m):
        return float(dent.radius_m[k])
    # between node k (at or above the level) and k + 1 (below), linearly
    level = fraction * abs(dent.centre_depth_m)
    d0, d1 = abs(dent.depth_m[k]), abs(dent.depth_m[k + 1])
    r0, r1 = dent.radius_m[k], dent.radius_m[k + 1]
    return float(r0 + (d0 - level) / (d0 - d1) * (r1 - r0)) if d0 > d1 else float(r0)


def hollow_radius(dent: ResidualDent) -> float:
    """Where the hollow ends (m): the first radius at which D falls to 0, linearly between the
    nodes (beyond it the surface stands proud of the sphere: the rim); the last node's radius
    if D never does."""
    below = np.nonzero(dent.depth_m <= 0.0)[0]
    if len(below) == 0:
        return float(dent.radius_m[-1])
    k = int(below[0])
    d0, d1 = dent.depth_m[k - 1], dent.depth_m[k]
    r0, r1 = dent.radius_m[k - 1], dent.radius_m[k]
    return float(r0 + d0 / (d0 - d1) * (r1 - r0))


def rim(dent: ResidualDent) -> tuple[float, float]:
    """The rim round the hollow: its height as the most negative D (m; 0 if there is none) and
    its radius (m)."""
    k = int(np.argmin(dent.depth_m))
    return (min(float(dent.depth_m[k]), 0.0), float(dent.radius_m[k]))


def _disc_points(offset: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Distances from the dent's centre of quadrature points over a disc of ``radius`` centred
    at ``offset``, and their punch weights (summing to 1): t = a sin(phi), so that
    (a^2 - t^2)^(-1/2) t dt = a sin(phi) dphi (Gauss-Legendre in phi over [0, pi/2])."""
    x, w = np.polynomial.legendre.leggauss(PUNCH_RADIAL_POINTS)
    phi = 0.25 * math.pi * (x + 1.0)
    weight_phi = 0.25 * math.pi * w * np.sin(phi)
    theta = (np.arange(PUNCH_ANGULAR_POINTS) + 0.5) * 2.0 * math.pi / PUNCH_ANGULAR_POINTS
    t = radius * np.sin(phi)[:, None]
    px = offset + t * np.cos(theta)[None, :]
    py = t * np.sin(theta)[None, :]
    weights = np.repeat(weight_phi[:, None], len(theta), axis=1)
    return np.hypot(px, py), weights / weights.sum()


def punch_mean(dent: ResidualDent, offset: float, radius: float | None = None) -> float:
    """The punch-weighted mean of D over a new contact disc of ``radius`` (default a_max)
    centred ``offset`` from the dent's centre (m): the change of approach the new contact feels
    from the dent, to first order (module docstring)."""
    a = dent.contact_radius_m if radius is None else radius
    distance, weights = _disc_points(offset, a)
    return float(np.sum(dent.depth_at(distance) * weights))


def disc_peak(dent: ResidualDent, offset: float, radius: float | None = None) -> float:
    """The largest |D| over the closed disc of ``radius`` (default a_max) centred at ``offset``
    (m): the deepest part of the dent a new contact there covers."""
    a = dent.contact_radius_m if radius is None else radius
    near = max(offset - a, 0.0)
    inside = (dent.radius_m >= near) & (dent.radius_m <= offset + a)
    ends = np.abs(dent.depth_at(np.array([near, offset + a])))
    return float(max(np.max(np.abs(dent.depth_m[inside]), initial=0.0), np.max(ends)))


def clear_offset(dent: ResidualDent, fraction: float) -> float:
    """The smallest offset s (m) beyond which a new contact disc of radius a_max feels less than
    ``fraction`` of the dent's centre depth (|``punch_mean``|: the hollow or the rim), found on
    a grid of a_max / 50: the travel after which the dent may be forgotten at that tolerance."""
    a = dent.contact_radius_m
    offsets = np.arange(0.0, 8.0 * a, a / 50.0)
    level = fraction * abs(dent.centre_depth_m)
    felt = np.array([abs(punch_mean(dent, s)) for s in offsets])
    above = np.nonzero(felt >= level)[0]
    if len(above) == 0:
        return 0.0
    k = int(above[-1])
    if k + 1 >= len(offsets):
        return float(offsets[k])
    f0, f1 = felt[k], felt[k + 1]
    return float(offsets[k] + (f0 - level) / (f0 - f1) * (offsets[k + 1] - offsets[k]))


def plastic_zone_radius(solver, state) -> float:
    """The largest radius (m, from the axis, any depth) of the quadrature points that yielded
    (equivalent plastic strain > 0): how far sideways the plastic zone under the dent reaches."""
    yielded = state.eqps > 0.0
    return float(np.max(solver.radius_qp[yielded], initial=0.0))
