"""Channels: movement modes (G and S), keyed curves, blending and key remapping
(Hecker et al. 2008, sections 3.2-3.3). See ``engine.channels.modes`` for the modes."""

from engine.channels.blend import channel_order, ownership
from engine.channels.curves import auto_tangents, rotation_auto_tangents, sample_rotation, sample_vector
from engine.channels.modes import (
                                   LOOKAT_LIMITS,
                                   POSITION_MODES,
                                   ROTATION_MODES,
                                   SAGITTAL_MIN,
                                   SCALE_MODES,
                                   PositionSpec,
                                   RotationSpec,
                                   Slot,
                                   SlotConstants,
                                   body_reach,
                                   build_slots,
                                   frames,
                                   generalize,
                                   ground_height,
                                   specialize,
)
from engine.channels.remap import remap_position_keys, remap_rotation_keys

__all__ = ["LOOKAT_LIMITS", "POSITION_MODES", "ROTATION_MODES", "SAGITTAL_MIN", "SCALE_MODES", "PositionSpec",
           "RotationSpec", "Slot", "SlotConstants", "auto_tangents", "body_reach", "build_slots",
           "channel_order", "frames", "generalize", "ground_height", "ownership", "remap_position_keys",
           "remap_rotation_keys", "rotation_auto_tangents", "sample_rotation", "sample_vector", "specialize"]
