"""A small NumPy mass-spring body on a tetrahedral mesh, for the examples in this folder.

Lumped tet masses, one damped spring per tet edge, and a volume spring per tet; explicit
substeps for the internal forces and a linearly implicit per-node update for the contact
forces and 3x3 stiffness blocks the service sends (docs/PYTHON.md):

    (m I - h^2 K_i) dv_i = h f_i + h^2 K_i v_i        (h: the frame's step)

Pinned nodes (a boolean mask) never move.
"""
import numpy as np


class MassSpring:
    """A mass-spring body: lumped tet masses, one damped spring per tet edge."""

    def __init__(self, nodes, tets, density=1000.0, spring=2.0e4, spring_damping=5.0, bulk=2.0e5,
                 pinned=None):
        self.x = nodes.copy()
        self.v = np.zeros_like(nodes)
        self.tets = tets
        self.volume = self.volumes_and_gradients()[0]
        self.mass = np.bincount(tets.ravel(), np.repeat(density * self.volume / 4.0, 4), len(nodes))
        self.bulk = bulk
        pairs = tets[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2)
        self.edges = np.unique(np.sort(pairs, axis=1), axis=0)
        self.rest = np.linalg.norm(nodes[self.edges[:, 1]] - nodes[self.edges[:, 0]], axis=1)
        self.spring = spring
        self.spring_damping = spring_damping
        self.free = None if pinned is None else ~np.asarray(pinned, dtype=bool)

    def volumes_and_gradients(self):
        """Signed tet volumes (m,) and their gradients by node (m, 4, 3)."""
        a, b, c, d = (self.x[self.tets[:, i]] for i in range(4))
        gb = np.cross(c - a, d - a) / 6.0
        gc = np.cross(d - a, b - a) / 6.0
        gd = np.cross(b - a, c - a) / 6.0
        volume = np.einsum("ij,ij->i", gd, d - a)
        return volume, np.stack([-(gb + gc + gd), gb, gc, gd], axis=1)

    def internal_forces(self):
        i, j = self.edges[:, 0], self.edges[:, 1]
        d = self.x[j] - self.x[i]
        length = np.linalg.norm(d, axis=1)
        u = d / length[:, None]
        rate = np.einsum("ij,ij->i", self.v[j] - self.v[i], u)
        f = (self.spring * (length - self.rest) + self.spring_damping * rate)[:, None] * u
        n = len(self.x)
        total = np.stack([np.bincount(i, f[:, k], n) - np.bincount(j, f[:, k], n) for k in range(3)],
                         axis=1)
        # Volume springs, E = bulk / 2 (V - V0)^2 / V0 per tet: they keep tets from inverting
        # where edge springs alone would let a tet flatten through itself.
        volume, gradient = self.volumes_and_gradients()
        fv = -(self.bulk * (volume - self.volume) / self.volume)[:, None, None] * gradient
        nodes = self.tets.ravel()
        fv = fv.reshape(-1, 3)
        return total + np.stack([np.bincount(nodes, fv[:, k], n) for k in range(3)], axis=1)

    def energy(self, gravity=9.81):
        """Kinetic + spring + volume-spring + gravity energy, J (gravity from z = 0)."""
        i, j = self.edges[:, 0], self.edges[:, 1]
        length = np.linalg.norm(self.x[j] - self.x[i], axis=1)
        springs = 0.5 * self.spring * np.sum((length - self.rest) ** 2)
        volume = self.volumes_and_gradients()[0]
        volumes = 0.5 * self.bulk * np.sum((volume - self.volume) ** 2 / self.volume)
        kinetic = 0.5 * np.sum(self.mass[:, None] * self.v * self.v)
        return kinetic + springs + volumes + gravity * np.sum(self.mass * self.x[:, 2])

    def min_volume_ratio(self):
        """Smallest current / rest tet volume (<= 0: a tet inverted)."""
        return float(np.min(self.volumes_and_gradients()[0] / self.volume))

    def apply_contact(self, nodes, forces, stiffness, h, damping=None):
        """Linearly implicit contact impulse on the nodes in contact (k,), (k, 3), (k, 3, 3).

        damping: the df/dv blocks (k, 3, 3) of the contact damping and friction, or None:
        m dv = h (f + h K (v + dv) + D dv), solved node by node."""
        if len(nodes) == 0:
            return
        m = self.mass[nodes][:, None, None] * np.eye(3)
        lhs = m - h * h * stiffness
        if damping is not None:
            lhs = lhs - h * damping
        rhs = h * forces + h * h * np.einsum("kij,kj->ki", stiffness, self.v[nodes])
        self.v[nodes] += np.linalg.solve(lhs, rhs[:, :, None])[:, :, 0]
        if self.free is not None:
            self.v[~self.free] = 0.0

    def step(self, h, substeps, gravity=9.81):
        dt = h / substeps
        for _ in range(substeps):
            a = self.internal_forces() / self.mass[:, None]
            a[:, 2] -= gravity
            if self.free is not None:
                a[~self.free] = 0.0
            self.v += dt * a
            self.x += dt * self.v
