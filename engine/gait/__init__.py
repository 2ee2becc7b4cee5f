"""Gaits for any arrangement of legs (Hecker et al. 2008, section 4.2).

``GaitController(creature)`` is the runtime's gait stage (``Character.locomote`` makes
one): legs clustered into groups of roughly equal length and harmonized by small
rational frequency ratios (``engine.gait.rig``), authored gait styles interpolated by
speed with procedural waves for 7+ feet (``engine.gait.style``, files in
``animations/gaits``), feet planted in world space during stance and carried along the
style's flight path, hip motion and root motion, floating and inch-worm crawling for
creatures without feet. The per-frame work is one numba kernel for any number of
characters (``engine.gait._step_kernels.gait_rows``, around ``engine.gait._kernels``;
a crowd steps all its walking members of a creature in one call), with the game's terrain
height function, when there is one, called from Python between its two halves. ``PathFollower`` turns a
polyline into locomote commands; ``engine.validation.gait`` measures a gait on the runtime's
output (``benchmarks/gait.py``).
"""

from engine.gait.controller import GaitController, GaitError
from engine.gait.path import PathFollower, heading_of
from engine.gait.rig import GaitRig, analyze, cluster_lengths, decide_mode, harmonize
from engine.gait.style import GaitStyle, GaitStyleError, load_style, parse_style_text, style_names

__all__ = ["GaitController", "GaitError", "GaitRig", "GaitStyle", "GaitStyleError", "PathFollower", "analyze",
           "cluster_lengths", "decide_mode", "harmonize", "heading_of", "load_style", "parse_style_text",
           "style_names"]
