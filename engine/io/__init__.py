"""Formats at the border: BVH motion capture in and out, BVH skeletons as creatures.

BVH is Y up; everything here converts to Menagerie axes (Z up, X forward, Y left) on the
way in and back on the way out, so nothing inside the engine sees file axes.
"""

from engine.io.bvh import (
    AXIS_MAP,
    CHANNEL_NAMES,
    UNIT_SCALES,
    BvhClip,
    BvhWarning,
    auto_scale,
    bvh_text,
    load_bvh,
    parse_bvh_text,
    quat_to_menagerie_axes,
    save_bvh,
    to_menagerie_axes,
)
from engine.io.bvh_creature import (
    DEFAULT_CAPS_TABLE,
    CapsTableError,
    bvh_body_poses,
    creature_def_from_bvh,
    creature_from_bvh,
    joint_caps,
    load_caps_table,
)

__all__ = [
    "AXIS_MAP", "CHANNEL_NAMES", "DEFAULT_CAPS_TABLE", "UNIT_SCALES", "BvhClip", "BvhWarning",
    "CapsTableError", "auto_scale", "bvh_body_poses", "bvh_text", "creature_def_from_bvh", "creature_from_bvh",
    "joint_caps", "load_bvh", "load_caps_table", "parse_bvh_text", "quat_to_menagerie_axes",
    "save_bvh", "to_menagerie_axes",
]
