"""The converged state of the hemisphere at the end of a load step (``ContactSolver``'s
``State``): plain arrays, saved in checkpoints and snapshots (``fem.checkpoint``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class State:
    """Converged state at the end of a load step (plain arrays; the half-model = one sphere)."""

    displacement: np.ndarray  # (ndofs,)
    top_displacement: float  # w: downward motion of the equatorial face = ball-wall approach
    stress: np.ndarray  # (4, elements, points)
    strain: np.ndarray  # (4, elements, points)
    eqps: np.ndarray  # (elements, points)
    status: np.ndarray  # (elements, points) ELASTIC / CONE / APEX in the last increment
    active: np.ndarray  # (candidates,) bool, nodes in contact
    force: float = 0.0  # N
    plastic_dissipation: float = 0.0  # J, cumulative, one sphere
    work: float = 0.0  # J, cumulative work of the force, one sphere
    iterations: int = 0

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "displacement": self.displacement, "top_displacement": np.array(self.top_displacement),
            "stress": self.stress, "strain": self.strain, "eqps": self.eqps,
            "status": self.status, "active": self.active, "force": np.array(self.force),
            "plastic_dissipation": np.array(self.plastic_dissipation),
            "work": np.array(self.work),
        }

    @classmethod
    def from_arrays(cls, data) -> State:
        return cls(
            displacement=np.array(data["displacement"]),
            top_displacement=float(data["top_displacement"]),
            stress=np.array(data["stress"]), strain=np.array(data["strain"]),
            eqps=np.array(data["eqps"]), status=np.array(data["status"]),
            active=np.array(data["active"], dtype=bool), force=float(data["force"]),
            plastic_dissipation=float(data["plastic_dissipation"]), work=float(data["work"]),
        )
