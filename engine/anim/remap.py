"""Key remapping of a whole channel when its movement mode changes (Hecker 2008, sec 3.3)."""

from __future__ import annotations

import dataclasses

import numpy as np

from engine.anim.animation import AnimationError, ChannelDef, Key
from engine.channels.remap import remap_position_keys, remap_rotation_keys


def _channel_curves(channel: ChannelDef, loop_length):
    """The channel's packed curves (with its automatic tangents filled in)."""
    from engine.anim.animation import Animation

    length = max([k.t for k in channel.position_keys + channel.rotation_keys + channel.weight_keys] + [1.0])
    if loop_length is not None:
        length = loop_length
    origin_pos = (Key(0.0, (0.0, 0.0, 0.0)),) if channel.position is not None else ()
    origin_rot = (Key(0.0, (1.0, 0.0, 0.0, 0.0)),) if channel.rotation is not None else ()
    ch = dataclasses.replace(channel, position_keys=channel.position_keys or origin_pos,
                             rotation_keys=channel.rotation_keys or origin_rot, events=())
    return Animation(name="remap", length=float(length), channels=(ch,), loop=loop_length is not None).curves


def remap_channel(channel: ChannelDef, creature, body: int, *, position=None, rotation=None, target=None,
                  loop_length: float | None = None) -> ChannelDef:
    """``channel`` with new movement modes and its keys remapped so that ``body`` (the
    active body, which the channel must select) keeps exactly the same specialized curve:
    ``q_g_new = G_new(b, S_old(b, q_g_old, false), false)`` for every key and tangent.
    ``target``: the secondary target position used for both modes (when either needs one).
    Every tangent is written out explicitly (automatic ones as the old curve computed
    them): automatic tangents are clamped per axis, so they would not survive a change
    of axes, and the curve must stay identical between keys too."""
    if body not in set(int(b) for b in channel.query.evaluate(creature)):
        raise AnimationError(f"body '{creature.body_names[body]}' is not selected by channel '{channel.name}'",
                             subject=channel.name, field="select")
    changes = {}
    cv = _channel_curves(channel, loop_length)
    if position is not None and channel.position is not None:
        keys = channel.position_keys or (Key(0.0, (0.0, 0.0, 0.0)),)
        values = np.array([k.value for k in keys], float).reshape(-1, 3)
        a, n = int(cv.ch_pos_adr[0]), int(cv.ch_pos_num[0])
        new_v, (new_in, new_out) = remap_position_keys(creature, body, channel.position, position, values,
                                                       (cv.pos_tin[a:a + n], cv.pos_tout[a:a + n]), target=target)
        changes["position"] = position
        changes["position_keys"] = tuple(
            Key(k.t, tuple(float(x) for x in new_v[j]),
                tuple(float(x) for x in new_in[j]), tuple(float(x) for x in new_out[j]))
            for j, k in enumerate(keys))
    if rotation is not None and channel.rotation is not None:
        keys = channel.rotation_keys or (Key(0.0, (1.0, 0.0, 0.0, 0.0)),)
        values = np.array([k.value for k in keys], float).reshape(-1, 4)
        a, n = int(cv.ch_rot_adr[0]), int(cv.ch_rot_num[0])
        new_v, (new_in, new_out) = remap_rotation_keys(creature, body, channel.rotation, rotation, values,
                                                       (cv.rot_tin[a:a + n], cv.rot_tout[a:a + n]), target=target)
        new_v = new_v / np.linalg.norm(new_v, axis=1, keepdims=True)
        changes["rotation"] = rotation
        changes["rotation_keys"] = tuple(
            Key(k.t, tuple(float(x) for x in new_v[j]),
                tuple(float(x) for x in new_in[j]), tuple(float(x) for x in new_out[j]))
            for j, k in enumerate(keys))
    return dataclasses.replace(channel, **changes)
