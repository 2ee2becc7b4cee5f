"""Jiggles: passive secondary motion for bodies nothing drives (Hecker et al. 2008, sec. 4.4)."""

from engine.jiggle.rig import JiggleRig, JiggleState, flexibility, jiggle_step

__all__ = ["JiggleRig", "JiggleState", "flexibility", "jiggle_step"]
