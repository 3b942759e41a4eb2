"""The default scene of the main job ``lieint compare`` (the study itself is :mod:`lieint.study`).

The embedded Dzhanibekov scene — an asymmetric 3D top (``I = (1, 2, 3)``) started close to its
unstable middle axis, where the body flips and the exact solution in Jacobi elliptic functions is
the reference — integrated to T = 100.
"""

from __future__ import annotations

from dataclasses import replace

__all__ = ["DEFAULT_T_END", "default_scene"]

DEFAULT_T_END = 100.0


def default_scene():
    """The default scene as a :class:`lieint.scenes.Scene`: the embedded Dzhanibekov top, T = 100."""
    from .scenes import embedded_scene

    return replace(embedded_scene("dzhanibekov"), t_end=DEFAULT_T_END, name="default scene (Dzhanibekov top)")
