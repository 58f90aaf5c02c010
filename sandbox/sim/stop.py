"""The paper's stop rule (§2.2): max displacement < 1.5 mm and mean < 0.1 mm.

Displacements are measured over one output frame of simulated time (default 1/30 s), not
one step, so the rule means the same at any dt. The rule must hold for ``frames``
consecutive frames.
"""

import taichi as ti


@ti.data_oriented
class DisplacementMonitor:
    """Max and mean |x(t) − x(t − frame)| over free particles [m]."""

    def __init__(self, model):
        self.model = model
        n = max(1, model.particle_count)
        self.reference = ti.Vector.field(3, float, shape=n)
        self.max_disp = ti.field(ti.f64, shape=())
        self.sum_disp = ti.field(ti.f64, shape=())
        self.free_count = max(1, int((~model.pinned_np).sum()))

    def reset(self, state) -> None:
        """Take the current positions as the reference."""
        self._copy(state.x)

    def measure(self, state) -> tuple[float, float]:
        """(max, mean) displacement since the reference [m]; the reference moves to now."""
        self.max_disp[None] = 0.0
        self.sum_disp[None] = 0.0
        self._measure(state.x)
        return float(self.max_disp[None]), float(self.sum_disp[None]) / self.free_count

    @ti.kernel
    def _copy(self, x: ti.template()):
        for i in range(self.model.particle_count):
            self.reference[i] = x[i]

    @ti.kernel
    def _measure(self, x: ti.template()):
        for i in range(self.model.particle_count):
            if self.model.particle_inv_mass[i] > 0.0:
                d = ti.cast((x[i] - self.reference[i]).norm(), ti.f64)
                ti.atomic_max(self.max_disp[None], d)
                self.sum_disp[None] += d
            self.reference[i] = x[i]


class StopRule:
    """Counts consecutive frames under both thresholds."""

    def __init__(self, max_m: float = 1.5e-3, mean_m: float = 1.0e-4, frames: int = 1):
        self.max_m, self.mean_m, self.frames = max_m, mean_m, frames
        self.streak = 0

    def update(self, max_disp: float, mean_disp: float) -> bool:
        """Feed one frame's displacements; True once the rule has held ``frames`` times."""
        ok = max_disp < self.max_m and mean_disp < self.mean_m
        self.streak = self.streak + 1 if ok else 0
        return self.streak >= self.frames
