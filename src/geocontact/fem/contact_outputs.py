"""What a converged state says about the contact (mixed into
:class:`~geocontact.fem.solver.ContactSolver`): the contact forces, pressure and radius, the
yield measure at every point and at the contact edge, and the yielded part of the contact.

``ContactOutputs`` reads the solver's mesh data (``mesh``, ``basis``, ``candidate_*``,
``radius_qp``, ``z_qp``, ``model``, ``material``) and its ``gaps``, ``state_internal_force``
and ``tolerance``; the finite-strain solver overrides ``candidate_radii`` and
``contact_pressure`` (the current configuration).
"""

from __future__ import annotations

import math

import numpy as np

from .plasticity import yield_ratio
from .state import State

TWO_PI = 2.0 * math.pi
# A point counts as yielding (fully plastic onset, docs/model.md §4) when its Drucker-Prager ratio
# is within 1 % of the yield surface: a point that yielded and unloads by round-off still counts.
YIELD_RATIO_AT_YIELD = 0.99
# The surface stress at the contact edge (edge_surface_ratio) is extrapolated from this many
# surface facets just outside the contact (measured on the default mesh at 50 and 55 deg, 0.95-1.05
# Fy: 2 facets differ from 3 by up to 1.2 %, 3, 4 and 6 agree within 0.4 %)
EDGE_SURFACE_FACETS = 3


class ContactOutputs:
    """The contact's outputs of a converged state (mixed into ``ContactSolver``)."""

    def sphere_facets(self) -> np.ndarray:
        """Boundary facets on the spherical surface (both end vertices on the sphere)."""
        radius = self.material.radius
        facets = self.mesh.boundary_facets()
        ends = self.mesh.p[:, self.mesh.facets[:, facets]]  # (2, 2, facets)
        dist = np.hypot(ends[0], ends[1] - radius)
        on = np.all(np.abs(dist - radius) < 1e-7 * radius, axis=0)
        return facets[on & (np.max(ends[0], axis=0) > 0.0)]

    def _tributary_areas(self, cand_points: np.ndarray,
                         displacement: np.ndarray | None = None) -> np.ndarray:
        """Ring area carried by each contact node: integral of its z shape function * 2 pi r
        over the sphere's surface; with ``displacement``, over the surface of the current
        configuration (r = R + u_r, line element |F t| dS with t the reference unit tangent)."""
        from skfem import ElementTriP2, ElementVector, FacetBasis, LinearForm

        facets = self.sphere_facets()
        fb = FacetBasis(self.mesh, ElementTriP2(), facets=facets, intorder=6)

        @LinearForm
        def ring(v, w):
            return TWO_PI * w.x[0] * v

        if displacement is None:
            return ring.assemble(fb)[cand_points]
        vb = FacetBasis(self.mesh, ElementVector(ElementTriP2()), facets=facets, intorder=6)
        u = vb.interpolate(displacement)

        @LinearForm
        def current_ring(v, w):
            t_r, t_z = -w.n[1], w.n[0]  # reference unit tangent
            du = w.u.grad  # (2, 2, ...): du_i/dX_k
            stretch = np.hypot(t_r + du[0, 0] * t_r + du[0, 1] * t_z,
                               t_z + du[1, 0] * t_r + du[1, 1] * t_z)
            return TWO_PI * (w.x[0] + w.u[0]) * stretch * v

        return current_ring.assemble(fb, u=u)[cand_points]

    def candidate_radii(self, state: State) -> np.ndarray:
        """Radii of the contact candidate nodes (in the configuration of ``state``)."""
        return self.candidate_r

    def contact_forces(self, state: State) -> np.ndarray:
        if self.contact == "facet":  # at F = 0 open (``_iterate_facet``)
            if state.force == 0.0:
                return np.zeros(len(self.candidate_dofs))
            return self.facet_contact.forces(state.displacement)[self.candidate_dofs]
        f = self.state_internal_force(state)[self.candidate_dofs]
        return np.where(state.active, f, 0.0)

    def contact_pressure(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """(r, pressure) at the surface nodes: nodal force / tributary ring area (with
        ``contact="facet"`` the same: the penalty pressure at a node, epsilon times a gap of
        ~1e-10 m, carries the displacement's discretisation error and is ~10 % off; the far node
        of the facet the contact edge is in can carry a small negative consistent force)."""
        return self.candidate_r, self._pressure(self.contact_forces(state), self.candidate_area)

    def _pressure(self, force: np.ndarray, area: np.ndarray) -> np.ndarray:
        """Nodal force / ring area; the axis node's ring area is zero (its P2 shape function
        gives int N r ds = 0 on the first edge; round-off leaves ~1e-10 of the largest, which
        made a 700 sigma_c spike), so it takes its neighbour's pressure."""
        axis = self.candidate_r <= 1e-12 * self.material.radius
        pressure = np.divide(force, area, out=np.zeros_like(area), where=~axis & (area > 0.0))
        pressure[axis] = pressure[1]
        return pressure

    def contact_radius(self, state: State) -> float:
        """Radius of the contact circle.

        The outermost touching node bounds it from below, the first open node from above; in
        between the edge is placed where the gap of the next two open nodes, extrapolated with
        the Hertzian edge law g ~ (r - a)^(3/2), vanishes. The same with ``contact="facet"``
        (a node touches when its penalty force does): the zero of the interpolated gap lags the
        edge by up to an element, the gap inside being the small penetration.
        """
        # nodes carrying more than the equilibrium tolerance (at F = 0 none does)
        threshold = 10.0 * self.tolerance * max(state.force, 1e-3 * self.force_scale)
        active = state.active & (self.contact_forces(state) > threshold)
        if not active.any():
            return 0.0
        last = int(np.nonzero(active)[0][-1])
        r = self.candidate_radii(state)
        if last + 2 >= len(r):
            return float(r[last])
        g = self.gaps(state.displacement)
        g1, g2 = g[last + 1], g[last + 2]
        if not (g1 > 0 and g2 > g1):
            return float(r[last])
        k = (g1 / g2) ** (2.0 / 3.0)
        a = (r[last + 1] - k * r[last + 2]) / (1.0 - k)
        return float(np.clip(a, r[last], r[last + 1]))

    def yield_ratio(self, state: State) -> np.ndarray:
        """Drucker-Prager measure at every point (1 on the yield surface)."""
        return yield_ratio(self.model, state.stress, state.eqps)

    def edge_surface_ratio(self, state: State) -> tuple[float, float]:
        """(ratio, a): the Drucker-Prager ratio on the surface at the contact edge r = a
        (``contact_radius``), where the analytic first yield is above the critical friction
        angle (grain.hertz); 0 without contact. Used only to locate first yield.

        The ratio has a cusp there (a square-root fall inside the contact and under the
        surface), which the quadrature points, off the surface, sample below its peak
        (docs/verification/edge_first_yield.md). Outside the contact the surface is traction
        free and its field smooth (Hertz: sigma_rr = -sigma_tt ~ (a / r)^2, Johnson 1985
        §3.4), so the edge value is recovered from outside: on each of the first
        ``EDGE_SURFACE_FACETS`` surface facets beyond a, the surface strains at the facet's two
        Gauss points (where the derivative of the P2 displacement is superconvergent) from the
        displacement of its three nodes, e_ss = t . du/ds, e_tt = u_r / r, give the plane
        stress of a free surface; each component, fitted linearly in (a / r)^2, is taken to
        r = a. From the displacement rather than the quadrature stresses: those carry the
        element-constant volumetric part of B-bar, which is not the surface's.
        """
        a = self.contact_radius(state)
        if a <= 0.0:
            return 0.0, 0.0
        facets = self.sphere_facets()
        ends = self.mesh.facets[:, facets]
        nodes = np.stack([ends[0], facets, ends[1]])  # (vertex, facet, vertex) of each facet
        inner = np.min(self.mesh.p[0, ends], axis=0)
        beyond = np.nonzero(inner >= a)[0]
        beyond = beyond[np.argsort(inner[beyond])][:EDGE_SURFACE_FACETS]
        if len(beyond) < 2:
            return 0.0, a
        r, s_ss, s_tt = self._free_surface_stress(state, nodes[:, beyond])
        x = (a / r) ** 2
        at_edge = [np.polyval(np.polyfit(x, s, 1), 1.0) for s in (s_ss, s_tt)]
        stress = np.array([[at_edge[0]], [0.0], [at_edge[1]], [0.0]])  # (tangent, normal, hoop)
        return float(yield_ratio(self.model, stress, np.zeros(1))[0]), a

    def _free_surface_stress(self, state: State, nodes: np.ndarray):
        """Radius and plane stress (tangent, hoop) of a traction-free surface at the two Gauss
        points of each P2 surface facet, ``nodes`` (3, facets): its first vertex, itself (its
        middle dof), its second vertex."""
        basis, u = self.basis, state.displacement
        dofs = [np.stack([basis.nodal_dofs[c][nodes[0]], basis.facet_dofs[c][nodes[1]],
                          basis.nodal_dofs[c][nodes[2]]]) for c in (0, 1)]
        position = np.stack([basis.doflocs[c, dofs[c]] for c in (0, 1)])  # (2, 3, facets)
        displacement = np.stack([u[dofs[c]] for c in (0, 1)])
        modulus, nu = self.material.youngs_modulus, self.material.poissons_ratio
        radii, tangent, hoop = [], [], []
        for xi in 0.5 + np.array([-0.5, 0.5]) / math.sqrt(3.0):
            n = np.array([(1.0 - xi) * (1.0 - 2.0 * xi), 4.0 * xi * (1.0 - xi),
                          xi * (2.0 * xi - 1.0)])
            dn = np.array([4.0 * xi - 3.0, 4.0 - 8.0 * xi, 4.0 * xi - 1.0])
            dx = np.einsum("n,cnf->cf", dn, position)
            ds = np.hypot(dx[0], dx[1])
            r = n @ position[0]
            e_ss = np.einsum("cf,cf->f", dx / ds, np.einsum("n,cnf->cf", dn, displacement)) / ds
            e_tt = (n @ displacement[0]) / r
            radii.append(r)
            tangent.append(modulus / (1.0 - nu**2) * (e_ss + nu * e_tt))
            hoop.append(modulus / (1.0 - nu**2) * (e_tt + nu * e_ss))
        return np.concatenate(radii), np.concatenate(tangent), np.concatenate(hoop)

    def surface_layer(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The quadrature points just under the spherical surface and the strip each stands for.

        For every surface facet, the three quadrature points of its element nearest the facet
        (with the 6-point rule about 0.1 of the element height deep, so the layer thins with the
        mesh); each represents the part of the facet between the radii halfway to its
        neighbours. Returns flat arrays (elements, points, r_inner, r_outer).
        """
        key = "surface_layer"
        if key not in self._cache:
            facets = self.sphere_facets()
            ends = self.mesh.p[:, self.mesh.facets[:, facets]]  # (r/z, end, facet)
            elements = self.mesh.f2t[0, facets]
            (r1, r2), (z1, z2) = ends
            qr, qz = self.radius_qp[elements], self.z_qp[elements]
            chord = np.hypot(r2 - r1, z2 - z1)[:, None]
            depth = np.abs((r2 - r1)[:, None] * (z1[:, None] - qz)
                           - (z2 - z1)[:, None] * (r1[:, None] - qr)) / chord
            points = np.argsort(depth, axis=1)[:, :3]
            radii = np.take_along_axis(qr, points, axis=1)
            order = np.argsort(radii, axis=1)
            points = np.take_along_axis(points, order, axis=1)
            radii = np.take_along_axis(radii, order, axis=1)
            bounds = np.stack([np.minimum(r1, r2), 0.5 * (radii[:, 0] + radii[:, 1]),
                               0.5 * (radii[:, 1] + radii[:, 2]), np.maximum(r1, r2)], axis=1)
            self._cache[key] = (np.repeat(elements, 3), points.ravel(),
                                bounds[:, :3].ravel(), bounds[:, 1:].ravel())
        return self._cache[key]

    def yielded_contact_fraction(self, state: State, extent: float = 1.0) -> float:
        """Fraction of the projected area of the disc r < extent * a (a the contact radius)
        whose surface layer (:meth:`surface_layer`) is at yield, i.e. within
        ``YIELD_RATIO_AT_YIELD`` of the yield surface (docs/model.md §4, Fp); 0 without contact.
        """
        a = extent * self.contact_radius(state)
        if a <= 0.0:
            return 0.0
        elements, points, r_inner, r_outer = self.surface_layer()
        area = np.clip(r_outer, 0.0, a) ** 2 - np.clip(r_inner, 0.0, a) ** 2
        at_yield = self.yield_ratio(state)[elements, points] >= YIELD_RATIO_AT_YIELD
        return float(np.sum(area[at_yield]) / a**2)
