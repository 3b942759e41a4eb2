"""The default scene of the main job ``lieint compare`` (the study itself is :mod:`lieint.study`).

An asymmetric 3D top (``I = (1, 2, 3)``) started close to its unstable middle axis, where the
body flips (the Dzhanibekov effect) and the exact solution in Jacobi elliptic functions is the
reference.
"""

from __future__ import annotations

from dataclasses import dataclass

from .systems.euler_top import EulerTop

__all__ = ["DefaultScene", "default_scene"]


def default_scene():
    """The embedded default scene as a :class:`lieint.scenes.Scene`: the Dzhanibekov top, T = 100."""
    from dataclasses import replace

    from .scenes import embedded_scene

    return replace(embedded_scene("dzhanibekov"), t_end=DefaultScene().t_end, name="default scene (Dzhanibekov top)")


@dataclass(frozen=True)
class DefaultScene:
    """Asymmetric 3D top near its unstable middle axis (the Dzhanibekov flip)."""

    moments: tuple[float, float, float] = (1.0, 2.0, 3.0)
    angular_velocity: tuple[float, float, float] = (0.01, 1.0, 0.01)
    t_end: float = 100.0

    def build(self):
        top = EulerTop.from_principal_moments(self.moments)
        return top, top.initial_state(angular_velocity=self.angular_velocity)
