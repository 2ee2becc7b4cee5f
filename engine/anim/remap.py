"""Key remapping of a whole channel when its movement mode changes (Hecker 2008, sec 3.3)."""

from __future__ import annotations

import dataclasses

import numpy as np

from engine.anim.animation import AnimationError, ChannelDef, Key
from engine.channels.remap import remap_position_keys, remap_rotation_keys




def remap_channel(channel: ChannelDef, creature, body: int, *, position=None, rotation=None, target=None,
                  loop_length: float | None = None) -> ChannelDef:
    """``channel`` with new movement modes and its keys remapped so that ``body`` (the
    active body, which the channel must select) keeps exactly the same specialized curve:
    ``q_g_new = G_new(b, S_old(b, q_g_old, false), false)`` for every key and tangent.
    ``target``: the secondary target position used for both modes (when either needs one).
    Explicit tangents are remapped; automatic ones stay automatic (they are linear in the
    keys, so they remap by themselves)."""
    if body not in set(int(b) for b in channel.query.evaluate(creature)):
        raise AnimationError(f"body '{creature.body_names[body]}' is not selected by channel '{channel.name}'",
                             subject=channel.name, field="select")
    changes = {}
    if position is not None and channel.position is not None:
        keys = channel.position_keys or (Key(0.0, (0.0, 0.0, 0.0)),)
        values = np.array([k.value for k in keys], float).reshape(-1, 3)
        tins = [np.array(k.tin if k.tin is not None else (0, 0, 0), float) for k in keys]
        touts = [np.array(k.tout if k.tout is not None else (0, 0, 0), float) for k in keys]
        new_v, (new_in, new_out) = remap_position_keys(creature, body, channel.position, position, values,
                                                       (np.array(tins).reshape(-1, 3), np.array(touts).reshape(-1, 3)),
                                                       target=target)
        changes["position"] = position
        changes["position_keys"] = tuple(
            Key(k.t, tuple(float(x) for x in new_v[j]),
                None if k.tin is None else tuple(float(x) for x in new_in[j]),
                None if k.tout is None else tuple(float(x) for x in new_out[j]))
            for j, k in enumerate(keys))
    if rotation is not None and channel.rotation is not None:
        keys = channel.rotation_keys or (Key(0.0, (1.0, 0.0, 0.0, 0.0)),)
        values = np.array([k.value for k in keys], float).reshape(-1, 4)
        tins = np.array([k.tin if k.tin is not None else (0, 0, 0) for k in keys], float).reshape(-1, 3)
        touts = np.array([k.tout if k.tout is not None else (0, 0, 0) for k in keys], float).reshape(-1, 3)
        new_v, (new_in, new_out) = remap_rotation_keys(creature, body, channel.rotation, rotation, values,
                                                       (tins, touts), target=target)
        new_v = new_v / np.linalg.norm(new_v, axis=1, keepdims=True)
        changes["rotation"] = rotation
        changes["rotation_keys"] = tuple(
            Key(k.t, tuple(float(x) for x in new_v[j]),
                None if k.tin is None else tuple(float(x) for x in new_in[j]),
                None if k.tout is None else tuple(float(x) for x in new_out[j]))
            for j, k in enumerate(keys))
    return dataclasses.replace(channel, **changes)
