"""Player kernel: advance every clip slot of one or many characters by one frame.

Slots are rows of (ncharacter, nslot) arrays, so a crowd advances in one call. Per slot:
the local time moves by ``dt * speed`` (wrapping for loops, clamping otherwise); the fade
moves toward 1 at ``fade_in_rate`` (1/s) or, once stopping, toward 0 at
``fade_out_rate``; a non-looping clip starts fading out by itself ``1 / fade_out_rate``
seconds before its end, so it is gone exactly when it ends (and holds its last pose while
it fades). A slot whose fade reaches 0 while stopping is freed. The effective weight is
``layer_weight[layer] * weight * smoothstep(fade)``: the smoothstep makes the fades C1,
so a pose blends in and out without a velocity kink.
"""

from __future__ import annotations

from numba import njit

# slot_flags bits (outputs of the kernel, cleared each call)
FLAG_ENDING = 1      # began fading out by reaching its end this frame (queue takes over)
FLAG_FREED = 2       # finished fading out this frame; the slot is free now
FLAG_WRAPPED = 4     # a looping clip wrapped this frame


@njit(cache=True)
def advance_slots(dt, slot_active, slot_time, slot_prev_time, slot_speed, slot_length, slot_loop,
                  slot_weight, slot_fade, slot_fade_in_rate, slot_fade_out_rate, slot_stopping,
                  slot_layer, layer_weight, slot_effective, slot_flags):
    """Advance all slots; shapes (nchar, nslot) except ``layer_weight`` (nchar, nlayer).
    Returns how many slots raised a flag (the caller's Python runs only when it is > 0)."""
    nchar, nslot = slot_active.shape
    flagged = 0
    for c in range(nchar):
        for s in range(nslot):
            slot_flags[c, s] = 0
            if not slot_active[c, s]:
                slot_effective[c, s] = 0.0
                continue
            length = slot_length[c, s]
            t0 = slot_time[c, s]
            t1 = t0 + dt * slot_speed[c, s]
            slot_prev_time[c, s] = t0
            if slot_loop[c, s]:
                if t1 >= length or t1 < 0.0:
                    t1 = t1 - length * (t1 // length)
                    slot_flags[c, s] |= FLAG_WRAPPED
            else:
                if t1 > length:
                    t1 = length
                elif t1 < 0.0:
                    t1 = 0.0
                # Fade out so the weight reaches 0 as the clip ends.
                if not slot_stopping[c, s]:
                    rate = slot_fade_out_rate[c, s]
                    lead = 0.0 if rate <= 0.0 else 1.0 / rate
                    speed = slot_speed[c, s]
                    remaining = (length - t1) if speed >= 0.0 else t1
                    if remaining <= lead * abs(speed) + 1e-12:
                        slot_stopping[c, s] = True
                        slot_flags[c, s] |= FLAG_ENDING
                        if rate > 0.0 and abs(speed) > 0.0 and remaining > 0.0:
                            # Fade exactly over the remaining play time.
                            slot_fade_out_rate[c, s] = slot_fade[c, s] * abs(speed) / remaining
            slot_time[c, s] = t1
            # Fades.
            f = slot_fade[c, s]
            if slot_stopping[c, s]:
                rate = slot_fade_out_rate[c, s]
                f = 0.0 if rate <= 0.0 else f - dt * rate
                if f <= 0.0:
                    f = 0.0
                    slot_active[c, s] = False
                    slot_flags[c, s] |= FLAG_FREED
            else:
                rate = slot_fade_in_rate[c, s]
                f = 1.0 if rate <= 0.0 else min(1.0, f + dt * rate)
            slot_fade[c, s] = f
            smooth = f * f * (3.0 - 2.0 * f)
            slot_effective[c, s] = layer_weight[c, slot_layer[c, s]] * slot_weight[c, s] * smooth
            if slot_flags[c, s] != 0:
                flagged += 1
    return flagged
