"""The per-frame goal kernel: sample curves, specialize (S) every slot, blend.

Hecker et al. 2008, section 4 (overview): "every frame, for any animations playing on a
character, the q_s for the channel's selected bodies are computed using S and blended
together". One call, no Python per channel or body, no allocation.
"""

from __future__ import annotations

from numba import njit

from engine.channels._kernels import blend_kernel, sample_rotation_into, sample_vector_into, specialize_slot_into
from engine.mathx.quat import quat_mul_into, quat_rotate_t, quat_slerp_t


@njit(cache=True)
def sample_channels_kernel(cv, t, ch_pos, ch_rot, ch_weight, work):
    """Every channel's generalized pose at animation time t: ch_pos (n, 3), ch_rot (n, 4),
    ch_weight (n,) clamped to [0, 1]. Channels without a curve get 0, identity, 1."""
    for c in range(ch_pos.shape[0]):
        if cv.ch_pos_num[c] > 0:
            sample_vector_into(cv.pos_time, cv.pos_value, cv.pos_tout, cv.pos_tin, cv.ch_pos_adr[c],
                               cv.ch_pos_num[c], t, ch_pos[c])
        else:
            ch_pos[c, 0] = 0.0
            ch_pos[c, 1] = 0.0
            ch_pos[c, 2] = 0.0
        if cv.ch_rot_num[c] > 0:
            sample_rotation_into(cv.rot_time, cv.rot_value, cv.rot_tout, cv.rot_tin, cv.ch_rot_adr[c],
                                 cv.ch_rot_num[c], t, ch_rot[c], work)
        else:
            ch_rot[c, 0] = 1.0
            ch_rot[c, 1] = 0.0
            ch_rot[c, 2] = 0.0
            ch_rot[c, 3] = 0.0
        if cv.ch_w_num[c] > 0:
            sample_vector_into(cv.w_time, cv.w_value, cv.w_tout, cv.w_tin, cv.ch_w_adr[c], cv.ch_w_num[c], t,
                               work[0, :1])
            ch_weight[c] = min(1.0, max(0.0, work[0, 0]))
        else:
            ch_weight[c] = 1.0


@njit(cache=True)
def goals_kernel(cv, c, slot_pos_on, slot_rot_on, targets, t, rest_pos, rest_rot, s, goal_pos, goal_rot,
                 goal_pos_weight, goal_rot_weight):
    """Goals of one animation at time t. ``cv`` the packed curves, ``c`` the slot
    constants (ownership order), ``s`` the scratch arrays (``EvalScratch``)."""
    sample_channels_kernel(cv, t, s.ch_pos, s.ch_rot, s.ch_weight, s.work33)
    for i in range(c.slot_body.shape[0]):
        ch = c.slot_channel[i]
        specialize_slot_into(c, i, targets, s.ch_pos[ch], s.ch_rot[ch], s.slot_pos[i], s.slot_rot[i], s.work33,
                             s.work34)
        s.slot_weight[i] = s.ch_weight[ch]
    blend_kernel(c.slot_body, slot_pos_on, slot_rot_on, s.slot_weight, s.slot_pos, s.slot_rot, rest_pos, rest_rot,
                 goal_pos, goal_rot, goal_pos_weight, goal_rot_weight)


@njit(cache=True)
def goals_kernel_body_targets(cv, c, slot_pos_on, slot_rot_on, targets, t, rest_pos, rest_rot, s, goal_pos,
                              goal_rot, goal_pos_weight, goal_rot_weight, body_parent, local_pos, local_rot, n_ext):
    """``goals_kernel`` for an animation with slots secondary-relative to the creature's own
    bodies (a hand brought to the mouth): where is the mouth? Not where it was last frame
    (the pose would then depend on the frames before it: a scrub, a skipped frame or a
    clip started mid-way would put the hand elsewhere), but where this frame's goals put
    it. Two passes: the goals with every body at rest, then the forward kinematics of those
    goals (``estimate_bodies``) as the body rows of the target table, and the goals again.
    Path independent, and a head that the same clip turns carries its mouth along."""
    for b in range(rest_pos.shape[0]):
        for j in range(3):
            targets[n_ext + b, j] = rest_pos[b, j]
    goals_kernel(cv, c, slot_pos_on, slot_rot_on, targets, t, rest_pos, rest_rot, s, goal_pos, goal_rot,
                 goal_pos_weight, goal_rot_weight)
    estimate_bodies(body_parent, local_pos, local_rot, rest_pos, rest_rot, goal_pos, goal_rot, goal_pos_weight,
                    goal_rot_weight, targets, n_ext, s.body_rot)
    goals_kernel(cv, c, slot_pos_on, slot_rot_on, targets, t, rest_pos, rest_rot, s, goal_pos, goal_rot,
                 goal_pos_weight, goal_rot_weight)


@njit(cache=True)
def estimate_bodies(body_parent, local_pos, local_rot, rest_pos, rest_rot, goal_pos, goal_rot, goal_pw, goal_rw,
                    out_pos, n_ext, out_rot):
    """Where the goals put each body, by forward kinematics from the root (character
    space, into ``out_pos[n_ext + b]`` and ``out_rot[b]``): a body's rotation is its
    parent's times its rest offset, turned toward its rotation goal by the goal's weight;
    its position its parent's frame carrying its rest offset, pulled toward its position
    goal by the weight. What the IK does with the goals only refines this."""
    for b in range(body_parent.shape[0]):
        p = body_parent[b]
        if p < 0:
            for j in range(4):
                out_rot[b, j] = rest_rot[b, j]
            for j in range(3):
                out_pos[n_ext + b, j] = rest_pos[b, j]
        else:
            quat_mul_into(out_rot[p], local_rot[b], out_rot[b])
            x, y, z = quat_rotate_t(out_rot[p], local_pos[b])
            out_pos[n_ext + b, 0] = out_pos[n_ext + p, 0] + x
            out_pos[n_ext + b, 1] = out_pos[n_ext + p, 1] + y
            out_pos[n_ext + b, 2] = out_pos[n_ext + p, 2] + z
        wr = min(max(goal_rw[b], 0.0), 1.0)
        if wr > 0.0:
            q0, q1, q2, q3 = quat_slerp_t(out_rot[b], goal_rot[b], wr)
            out_rot[b, 0] = q0
            out_rot[b, 1] = q1
            out_rot[b, 2] = q2
            out_rot[b, 3] = q3
        wp = min(max(goal_pw[b], 0.0), 1.0)
        if wp > 0.0:
            for j in range(3):
                out_pos[n_ext + b, j] += wp * (goal_pos[b, j] - out_pos[n_ext + b, j])
