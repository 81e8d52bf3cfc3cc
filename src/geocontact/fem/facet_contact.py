"""Segment-based penalty contact of the P2 surface facets on the rigid flat (``contact="facet"``).

The node-to-flat constraint of :class:`~geocontact.fem.solver.ContactSolver` (the default,
``contact="node"``) can only widen the contact one surface node at a time, and the loading
curve has a kink where a node engages (docs/fem.md, "The staircase of a growing contact").
Here the flat acts on the whole surface through a penalty pressure

    p(xi) = epsilon * <-g(xi)>,    g = z + u_z  (the current height of the surface point),

integrated over every facet of the spherical surface with the domain clipped at the zeros of the
gap (segment-based integration): on a P2 facet g is a quadratic of the facet coordinate xi, so
the part of the facet in contact is bounded by its roots, and the contact edge moves
continuously inside an element. The integrand vanishes at the edge, so the nodal contact forces

    f_i = int_{g < 0} p N_i 2 pi r ds

are continuously differentiable in the displacement, and their consistent tangent is

    K_ij = epsilon int_{g < 0} N_i N_j 2 pi r ds

(the moving edge adds nothing, p = 0 there). Gauss-Legendre with ``GAUSS_POINTS`` points on each
clipped interval: the integrand is a polynomial of degree 6 in xi times the arc length
|dx/dxi| of the curved facet.

Penalty: epsilon = ``PENALTY_FACTOR`` * E' / h on a facet of chord h (E' = E / (1 - nu^2), the
contact modulus of the ball-wall model), so the penetration p / epsilon is h p / (PENALTY_FACTOR
E'): for a Hertz contact (p0 = 2 E' a / (pi R), approach a^2 / R) a relative approach error
2 h / (pi PENALTY_FACTOR a), 2e-4 with 10 facets across the contact radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from .state import State

TWO_PI = 2.0 * math.pi
PENALTY_FACTOR = 300.0  # epsilon = PENALTY_FACTOR * E' / h (module docstring)
# The tangent of a contact that is open (to round-off) is replaced by a contact of the Hertz radius
# (``FacetContact.stiffness``) when its stiffness towards the flat is below this fraction of it.
OPEN_SUPPORT = 1e-6
GAUSS_POINTS = 5  # per clipped interval: exact for the polynomial part (degree 6) of the integrand
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(GAUSS_POINTS)


def shape(xi: np.ndarray) -> np.ndarray:
    """Quadratic shape functions of a facet (end 0, end 1, midpoint) at xi in [0, 1]: (3, ...)."""
    return np.stack([(1.0 - xi) * (1.0 - 2.0 * xi), xi * (2.0 * xi - 1.0), 4.0 * xi * (1.0 - xi)])


def shape_derivative(xi: np.ndarray) -> np.ndarray:
    return np.stack([4.0 * xi - 3.0, 4.0 * xi - 1.0, 4.0 - 8.0 * xi])


def penetrating_intervals(gap: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts of each facet where the quadratic gap through its nodal values ``gap`` (f, 3)
    is negative: (lower, upper, in_contact), each (f, 3) — every facet split at the roots of the
    gap in (0, 1) into three intervals (some of zero length)."""
    g0, g1, g2 = gap[:, 0], gap[:, 1], gap[:, 2]
    a = 2.0 * g0 + 2.0 * g1 - 4.0 * g2
    b = -3.0 * g0 - g1 + 4.0 * g2
    c = g0
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4.0 * a * c
        q = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
        roots = np.stack([q / a, c / q], axis=1)  # stable quadratic formula; a = 0: c / q only
    roots[~np.isfinite(roots) | (disc < 0.0)[:, None]] = 1.0
    roots = np.sort(np.clip(roots, 0.0, 1.0), axis=1)
    bounds = np.concatenate([np.zeros((len(gap), 1)), roots, np.ones((len(gap), 1))], axis=1)
    lower, upper = bounds[:, :-1], bounds[:, 1:]
    middle = 0.5 * (lower + upper)
    gap_middle = np.einsum("ifk,fi->fk", shape(middle), gap)
    return lower, upper, (gap_middle < 0.0) & (upper > lower)


@dataclass
class FacetContact:
    """The surface facets that may touch the flat, with what the contact integral needs."""

    element: np.ndarray  # (f,) the element each facet belongs to
    local: np.ndarray  # (f, 3) positions of the facet nodes' u_z among the element's 12 dofs
    dofs: np.ndarray  # (f, 3) their global dofs
    r: np.ndarray  # (f, 3) reference radius of the facet nodes (end 0, end 1, midpoint)
    z: np.ndarray  # (f, 3) reference height
    penalty: np.ndarray  # (f,) epsilon, Pa/m
    ndofs: int

    @classmethod
    def build(cls, mesh, basis, facets: np.ndarray, modulus: float) -> FacetContact:
        """``facets``: the candidate facets (mesh facet indices); ``modulus``: E'."""
        vertices = mesh.facets[:, facets]  # (2, f)
        nodal_z, facet_z = basis.nodal_dofs[1], basis.facet_dofs[1]
        dofs = np.stack([nodal_z[vertices[0]], nodal_z[vertices[1]], facet_z[facets]], axis=1)
        r, z = basis.doflocs[0][dofs], basis.doflocs[1][dofs]
        element = mesh.f2t[0, facets]
        element_dofs = basis.element_dofs[:, element].T  # (f, 12)
        local = np.argmax(element_dofs[:, :, None] == dofs[:, None, :], axis=1)
        assert np.all(np.take_along_axis(element_dofs, local, axis=1) == dofs)
        chord = np.hypot(r[:, 1] - r[:, 0], z[:, 1] - z[:, 0])
        return cls(element=element, local=local, dofs=dofs, r=r, z=z,
                   penalty=PENALTY_FACTOR * modulus / chord, ndofs=basis.N)

    def gap(self, displacement: np.ndarray) -> np.ndarray:
        """Nodal gaps (f, 3): the height of the facet nodes above the flat (with finite strain
        too: z0 + u_z is the current height)."""
        return self.z + displacement[self.dofs]

    def _points(self, gap: np.ndarray, whole: np.ndarray | None = None):
        """Quadrature on the penetrating part of every facet (``whole``: facets integrated over
        their full length instead): shape values (3, f, m), gaps (f, m), weights 2 pi r ds (f, m)
        and the upper ends of the contact intervals (f, 3, with -1 where not in contact)."""
        lower, upper, inside = penetrating_intervals(gap)
        if whole is not None:
            lower[whole], upper[whole] = np.array([0.0, 1.0, 1.0]), 1.0
            inside[whole] = np.array([True, False, False])
        half = 0.5 * (upper - lower)
        xi = (lower + half)[:, :, None] + half[:, :, None] * _GAUSS_X  # (f, 3, n)
        weight = np.where(inside, half, 0.0)[:, :, None] * _GAUSS_W
        xi = xi.reshape(len(gap), -1)
        weight = weight.reshape(len(gap), -1)
        n, dn = shape(xi), shape_derivative(xi)
        r = np.einsum("ifm,fi->fm", n, self.r)
        ds = np.hypot(np.einsum("ifm,fi->fm", dn, self.r), np.einsum("ifm,fi->fm", dn, self.z))
        g = np.einsum("ifm,fi->fm", n, gap)
        return n, g, TWO_PI * r * ds * weight, np.where(inside, upper, -1.0)

    def forces(self, displacement: np.ndarray) -> np.ndarray:
        """Nodal contact forces on the z dofs (global, > 0 pushing the sphere up)."""
        n, g, weight, _ = self._points(self.gap(displacement))
        pressure = self.penalty[:, None] * np.maximum(-g, 0.0)
        local = np.einsum("ifm,fm,fm->fi", n, pressure, weight)
        return np.bincount(self.dofs.ravel(), weights=local.ravel(), minlength=self.ndofs)

    def stiffness(self, displacement: np.ndarray, reach: float) -> np.ndarray:
        """Facet tangents (f, 3, 3) of the contact forces.

        Without penetration (a solve starting from an open contact; in practice: when the
        contact's stiffness towards the flat is below ``OPEN_SUPPORT`` of this one) the tangent
        takes the facets within the radius ``reach`` (the Hertz contact radius of the target
        force) as in contact over their length, at least the lowest one: the flat's support of
        the rigid motion then has the stiffness of a contact of about the right size (a sliver
        of penetration at the axis, where 2 pi r ~ 0, leaves the system singular to round-off).
        Only the Newton direction changes, not the solution.
        """
        gap = self.gap(displacement)
        n, _, weight, _ = self._points(gap)
        matrices = np.einsum("f,ifm,jfm,fm->fij", self.penalty, n, n, weight)
        whole = np.min(self.r, axis=1) < reach
        whole[np.argmin(np.min(gap, axis=1))] = True
        n, _, weight, _ = self._points(gap, whole)
        support = np.einsum("f,ifm,jfm,fm->fij", self.penalty, n, n, weight)
        # sum of all entries = the stiffness of a rigid motion towards the flat
        if np.sum(matrices) < OPEN_SUPPORT * np.sum(support):
            return support
        return matrices

    def add_to(self, local: np.ndarray, matrices: np.ndarray) -> np.ndarray:
        """Element matrices (elements, 12, 12) with the facet tangents added (a copy)."""
        out = local.copy()
        rows = np.broadcast_to(self.local[:, :, None], matrices.shape)
        cols = np.broadcast_to(self.local[:, None, :], matrices.shape)
        elems = np.broadcast_to(self.element[:, None, None], matrices.shape)
        np.add.at(out, (elems, rows, cols), matrices)
        return out

    def energy(self, displacement: np.ndarray) -> float:
        """Energy stored in the penalty layer, 1/2 int epsilon g^2 over the contact (J)."""
        n, g, weight, _ = self._points(self.gap(displacement))
        return float(0.5 * np.sum(self.penalty[:, None] * np.minimum(g, 0.0) ** 2 * weight))


# The line search of the elastic iterations (``FacetNewton._facet_line_search``) stops when the
# slope of the potential is down to this fraction of its start, or after this many evaluations.
FACET_SEARCH_SLOPE = 1e-2
FACET_SEARCH_STEPS = 30


class FacetNewton:
    """Newton's iteration with the facet contact (``contact="facet"``), mixed into
    :class:`~geocontact.fem.solver.ContactSolver`: it reads the solver's ``facet_contact``,
    evaluation (``_response``, ``_constitutive``), linear systems (``_reduced``, ``_factor``)
    and ``_finish``; the finite-strain solver overrides ``_bulk_force_along``."""

    def _iterate_facet(self, old: State, force: float, u: np.ndarray, w: float, *,
                       elastic: bool, label: str, final: bool = False):
        """Newton with the segment-based penalty contact (``contact="facet"``): no active set,
        the contact forces and their tangent are part of the residual and of the matrix; every
        candidate dof is free. Returns (u, w, State or None)."""
        contact = self.facet_contact
        scale = max(abs(force), 1e-3 * self.force_scale, 1e-30)
        tol = self.tolerance * scale
        top = self.top_dofs
        reduced = self._reduced(np.zeros(len(self.candidate_dofs), dtype=bool))
        free, n = reduced.free, reduced.n
        residual_norm = math.inf
        self.facet_residuals = []
        for iteration in range(1, self.max_iterations + 1):
            u[top] = -w
            stress, strain, eqps, status, f_int, tangent = self._response(old, u,
                                                                          elastic=elastic)
            if force == 0.0:
                # F = 0: the contact opens; the lowest surface node stays on the flat (as with
                # the node contact), held by a spring that carries no force at equilibrium
                gaps = self.gaps(u)
                lowest = self.candidate_dofs[np.argmin(gaps)]
                f_contact = np.zeros(self.ndofs)
                f_contact[lowest] = -self._touch_stiffness * np.min(gaps)
            else:
                f_contact = contact.forces(u)
            r_free = (f_int - f_contact)[free]
            r_top = -np.sum(f_int[top]) - force
            residual_norm = max(np.max(np.abs(r_free), initial=0.0), abs(r_top))
            self.facet_residuals.append(residual_norm)  # of the last solve (tests)
            if residual_norm <= tol and iteration > 1:
                if not final:
                    return u, w, None
                active = f_contact[self.candidate_dofs] > 0.0
                return u, w, self._finish(old, u, w, stress, strain, eqps, status, active,
                                          force, iteration)
            bulk = self.element_matrices(tangent)
            if force == 0.0:
                local = bulk.copy()
                self._add_touch(local, lowest)
            else:
                local = contact.add_to(bulk, contact.stiffness(u, self._hertz_radius(force)))
            factor = self._factor(local, reduced)
            if factor is None:
                break
            step = factor(np.concatenate([-r_free, [-r_top]]))
            if not np.all(np.isfinite(step)):
                break
            direction = np.zeros(self.ndofs)
            direction[free] = step[:n]
            direction[top] = -step[n]
            reach = self._admissible_length(u, direction)
            if reach is None:
                break
            if reach < 1.0:  # finite strain: the full step would turn an element inside out
                direction *= reach
                step = step * reach
            bulk_force = self._bulk_force_along(old, u, direction, f_int, bulk,
                                                elastic=elastic)
            length = 1.0 if force == 0.0 else self._facet_line_search(
                u, direction, bulk_force, force * step[n],
                float(np.dot(f_int - f_contact, direction)))
            u += length * direction
            w += length * step[n]
        if not final:
            return u, w, None
        raise ConvergenceError(
            f"{label}Newton did not converge at F = {force:.6g} N in {self.max_iterations} "
            f"iterations (residual {residual_norm:.3g} N, tolerance {tol:.3g} N)"
        )

    def _bulk_force_along(self, old: State, u: np.ndarray, direction: np.ndarray,
                          f_int: np.ndarray, bulk: np.ndarray, *, elastic: bool):
        """The internal force at u + a d as a function of a, for the facet line search
        (elastic small strain: linear in a, from the element matrices ``bulk``; else the
        return mapping at every a). ``FiniteStrainSolver`` evaluates its own kinematics."""
        if elastic:
            k_direction = self._local_product(bulk, direction)

            def bulk_force(a):
                return f_int + a * k_direction
            return bulk_force

        def bulk_force(a):
            stress = self._constitutive(old, self.strain(u + a * direction), tangent=False)[0]
            return self.internal_force(stress)
        return bulk_force

    def _hertz_radius(self, force: float) -> float:
        """Hertz contact radius of the hemisphere on the flat at ``force`` (ball-wall)."""
        e_wall = 2.0 * self.material.effective_modulus
        return (0.75 * force * self.material.radius / e_wall) ** (1.0 / 3.0)

    @property
    def _touch_stiffness(self) -> float:
        """Spring that keeps the lowest node on the flat at F = 0 (``contact="facet"``): the
        penalty factor times the hemisphere's stiffness scale E R."""
        return PENALTY_FACTOR * 2.0 * self.material.effective_modulus * self.material.radius

    def _add_touch(self, local: np.ndarray, dof: int) -> None:
        element = int(np.nonzero(np.any(self.element_dofs == dof, axis=0))[0][0])
        position = int(np.nonzero(self.element_dofs[:, element] == dof)[0][0])
        local[element, position, position] += self._touch_stiffness

    def _facet_line_search(self, u: np.ndarray, direction: np.ndarray, bulk_force,
                           load_rate: float, start: float) -> float:
        """Step length along a Newton direction with the penalty contact (``contact="facet"``).

        The increment (elastic, or with the return mapping of associated flow) is the minimum of
        a convex incremental potential, whose slope along the direction d is
        (f_int(u + a d) - f_contact(u + a d)) . d - F dw (``bulk_force(a)``: f_int at u + a d;
        elastic: linear in a, no constitutive evaluation; ``start``: the first term at a = 0).
        The full step is taken unless it
        passes the minimum by more than ``FACET_SEARCH_SLOPE`` of the starting slope, else the
        zero of the slope is found by regula falsi (Illinois). Without it Newton wanders for ~30
        iterations when the contact zone starts far from its size (the first step from an open
        contact), and fails on large plastic steps; near the solution a = 1, so the quadratic
        convergence is kept.
        """
        contact = self.facet_contact

        def slope(a: float) -> float:
            return float(np.dot(bulk_force(a) - contact.forces(u + a * direction),
                                direction)) - load_rate

        low, s_low = 0.0, start - load_rate
        if s_low >= 0.0:  # not a descent direction: the plain Newton step
            return 1.0
        enough = FACET_SEARCH_SLOPE * -s_low
        high, s_high = 1.0, slope(1.0)
        if s_high <= enough:
            return 1.0
        side = 0
        length = 1.0
        for _ in range(FACET_SEARCH_STEPS):
            length = (low * s_high - high * s_low) / (s_high - s_low)
            s = slope(length)
            if abs(s) <= enough:
                break
            if s < 0.0:
                low, s_low = length, s
                if side == -1:
                    s_high *= 0.5
                side = -1
            else:
                high, s_high = length, s
                if side == 1:
                    s_low *= 0.5
                side = 1
        return length
