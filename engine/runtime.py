"""The per-frame runtime: ``Character`` and ``Crowd``.

A game makes a ``Character`` per creature on screen, plays animations on it and calls
``tick(dt)`` once a frame; ``world_positions (nbody, 3)`` and ``world_rotations
(nbody, 4)`` then hold every body's pose (and ``skinning_matrices()`` the 4x4 matrices a
renderer skins with). A ``Crowd`` ticks many characters through the same kernels: the
characters of one creature live in rows of shared arrays (a *stack*), so each stage is
one kernel call per creature (and per animation variant, and per IK plan), never one per
character.

One frame (Hecker et al. 2008, section 4; ``../shared/DESIGN.md``)::

    player      advance clips, layers, queue          one kernel over the stack
    sample      curves of each playing clip at its time
    specialize  S per bound body                       one kernel per bound variant
    blend       clips by weight, layers bottom to top  one kernel over the stack
    gait        locomotion (engine.gait), or standing: feet the clips leave free held on the ground
    ik          two-phase particle IK                  one kernel per IK plan
    jiggle      passive secondary motion               } one kernel over the stack
    output      world placement of every body          }

Every stage can be switched off (``character.stages.ik = False``) for tests and the
viewer: with ``sample`` off the goals stay as they are, with ``ik`` off the bodies take
the root-relative rest pose carried by the root, with ``jiggle`` off the passive bodies
follow their parents rigidly. Nothing is allocated per frame after the first frame of a
new combination of playing clips (binding and IK plans are built once and cached).
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass

import numba
import numpy as np

from engine import _runtime_kernels as RK
from engine import compiling
from engine._fastcall import BoundKernel
from engine.anim.animation import Animation
from engine.anim.binding import Binding, BoundVariant, bind
from engine.anim.evaluate import default_target, has_body_targets, make_scratch, make_scratches
from engine.anim.player import CHANGES as _PLAYER_CHANGES
from engine.anim.player import EventCallback, Player, PlayerArrays, PlayHandle, advance_arrays
from engine.anim.variants import Variant
from engine.errors import MenagerieError
from engine.gait import _step_kernels as SK
from engine.ik.plan import IKParams, default_params, plan_for
from engine.jiggle.rig import JiggleRig
from engine.mathx import quat_mul_batch_into, quat_rotate_batch_into, quat_rotate_inv_into
from engine.model.caps import FOOT
from engine.model.creature import Creature

STAGES = ("player", "sample", "blend", "gait", "ik", "jiggle", "output")


@dataclass
class Stages:
    """Switches for the stages of ``tick`` (all on by default)."""

    player: bool = True
    sample: bool = True      # sample + specialize
    blend: bool = True
    gait: bool = True
    ik: bool = True
    jiggle: bool = True
    output: bool = True


class _Clip:
    """What the runtime attaches to a playing clip: the bound variant and its buffers."""

    __slots__ = ("animation", "binding", "bound", "scratch", "table", "n_ext", "calls", "body_targets")

    def __init__(self, animation: Animation, binding: Binding, bound: BoundVariant) -> None:
        self.animation = animation
        self.binding = binding
        self.bound = bound
        self.scratch = make_scratch(animation, bound)
        self.n_ext = len(bound.target_names)
        self.body_targets = has_body_targets(bound)
        self.table = np.zeros((1, self.n_ext + binding.creature.nbody, 3))
        self.calls: dict = {}      # (stack id, row, slot) -> the bound goals kernel

    def bound_call(self, char: Character, slot: int) -> BoundKernel:
        s, r = char._stack, char._row
        key = (id(s), r, slot)
        hit = self.calls.get(key)
        if hit is None:
            c = char.creature
            bv = self.bound
            hit = BoundKernel(RK.goals_pairs, (self.animation.curves, bv.slots, bv.slot_pos_on, bv.slot_rot_on,
                                               self.table, char._slot_time[slot], _row(r), _row(slot),
                                               c.body_rest_pos, c.body_rest_rot, self.scratch, s.sg_pos, s.sg_rot,
                                               s.sg_pw, s.sg_rw, self.n_ext, c.body_parent, c.body_local_pos,
                                               c.body_local_rot, self.body_targets))
            self.calls = {key: hit}   # a clip plays in one place at a time
        return hit


class _Stack:
    """The per-frame arrays of ``n`` characters of one creature (leading axis n)."""

    def __init__(self, creature: Creature, n: int, nslot: int, nlayer: int) -> None:
        nb = creature.nbody
        self.creature = creature
        self.n = n
        self.player = PlayerArrays.allocate(n, nslot, nlayer)
        self.sg_pos = np.zeros((n, nslot, nb, 3))
        self.sg_rot = np.zeros((n, nslot, nb, 4))
        self.sg_pw = np.zeros((n, nslot, nb))
        self.sg_rw = np.zeros((n, nslot, nb))
        self.goal_pos = np.zeros((n, nb, 3))
        self.goal_rot = np.zeros((n, nb, 4))
        self.goal_pw = np.zeros((n, nb))
        self.goal_rw = np.zeros((n, nb))
        self.root_pos = np.tile(creature.body_rest_pos[0], (n, 1))
        self.root_rot = np.tile(creature.body_rest_rot[0], (n, 1))
        self.place_pos = np.zeros((n, 3))
        self.place_rot = np.zeros((n, 4))
        self.place_rot[:, 0] = 1.0
        self.char_pos = np.tile(creature.body_rest_pos, (n, 1, 1))
        self.char_rot = np.tile(creature.body_rest_rot, (n, 1, 1))
        self.world_pos = self.char_pos.copy()
        self.world_rot = self.char_rot.copy()
        # impact response: last frame's displayed pose and the last dt (finite differences)
        self.prev_world_pos = self.world_pos.copy()
        self.prev_world_rot = self.world_rot.copy()
        self.last_dt = 1.0 / 60.0
        self.driven = np.zeros((n, nb), np.bool_)
        self.driven[:, 0] = True
        self.jig_err = np.zeros((n, nb, 3))
        self.jig_err_vel = np.zeros((n, nb, 3))
        self.jig_target = np.zeros((n, nb, 3))
        self.jig_target_vel = np.zeros((n, nb, 3))
        self.jig_active = np.zeros((n, nb), np.bool_)
        self.jig_twist = np.zeros((n, nb, 2))
        self.jig_contact = np.zeros((n, nb, 4))   # the turn the ground holds each passive body by
        self.jig_contact[:, :, 0] = 1.0
        #: The ground passive bodies rest on (n . x = d, world), where the gait sets it;
        #: otherwise the plane the character stands on (through its placement).
        self.ground = np.tile(np.array([0.0, 0.0, 1.0, 0.0]), (n, 1))
        self.ground_set = np.zeros(n, np.bool_)
        self.ik_bad = np.full(n, -1, np.int64)
        # the IK plan's hand-over (``_blend_switches``): a pending switch, the time since
        # one (-1: none running), the offsets of last frame's pose from the new plan's
        self.xf_pending = np.zeros(n, np.bool_)
        self.xf_t = np.full(n, -1.0)
        self.xf_pos = np.zeros((n, nb, 3))
        self.xf_rot = np.zeros((n, nb, 3))
        self.xf_live = False
        self.xf_hold = np.zeros(nb, np.bool_)      # scratch, one set reused across characters
        self.xf_foot = (creature.body_caps & np.uint32(FOOT)) != 0
        # blend scratch, one set reused across characters
        self.lay_pos = np.zeros((nb, 3))
        self.lay_rot = np.zeros((nb, 4))
        self.lay_pw = np.zeros(nb)
        self.lay_rw = np.zeros(nb)
        # jiggle scratch (the rigid chain pose), one set reused across characters
        self.jig_chain_joint = np.zeros((nb, 3))
        self.jig_chain_rot = np.zeros((nb, 4))
        # Kernels bound to these arrays (engine._fastcall), made on first use.
        self.blend_call = None
        self.output_call = None
        #: Rows whose feet stand (no locomotion controller): the gait stage holds their feet.
        self.stand = np.full(n, creature.nleg > 0, np.bool_)
        self.stand_call = None
        self.ground_call = None
        self.gait_args = None
        self.rows = np.arange(n, dtype=np.int64)

    _PER_CHAR = ("sg_pos", "sg_rot", "sg_pw", "sg_rw", "goal_pos", "goal_rot", "goal_pw", "goal_rw", "root_pos",
                 "root_rot", "place_pos", "place_rot", "char_pos", "char_rot", "world_pos", "world_rot", "driven",
                 "jig_err", "jig_err_vel", "jig_target", "jig_target_vel", "jig_active", "jig_twist", "jig_contact",
                 "ik_bad", "stand", "ground", "ground_set", "prev_world_pos", "prev_world_rot", "xf_pending", "xf_t",
                 "xf_pos", "xf_rot")

    def copy_row(self, dst: int, src: _Stack, row: int) -> None:
        for name in self._PER_CHAR:
            getattr(self, name)[dst] = getattr(src, name)[row]
        self.xf_live = self.xf_live or bool(src.xf_pending[row]) or bool(src.xf_t[row] >= 0.0)
        self.player.rows(dst, dst + 1).copy_from(src.player.rows(row, row + 1))


class Character:
    """One animated creature in the world (see the module docstring).

    >>> char = Character(engine.load_creature("creatures/humanoid.yaml"))
    >>> char.play(engine.load_animation("animations/wave.yaml"))
    >>> char.tick(1 / 60); char.world_positions
    """

    def __init__(self, creature: Creature, *, position=(0.0, 0.0, 0.0), heading: float = 0.0,
                 nslot: int = 8, nlayer: int = 4, ik_params: IKParams | None = None) -> None:
        if not isinstance(creature, Creature):
            raise TypeError(f"Character needs a Creature, got {type(creature).__name__}")
        compiling.notice("runtime")   # once per process, when numba's cache is cold
        self.creature = creature
        self.stages = Stages()
        self.player = Player(nslot, nlayer)
        self.ik_params = ik_params if ik_params is not None else default_params()
        self.jiggle_rig = JiggleRig.for_creature(creature)
        self._targets: dict[str, np.ndarray] = {}
        self._plan_key: int | None = None
        self._solve_call = None
        self._plan = None
        self._scratch_ik = None
        self._stack = _Stack(creature, 1, nslot, nlayer)
        self._row = 0
        self._bind_views()
        self.set_placement(position, heading, teleport=True)
        n = creature.nbody
        self._inv_bind = _inverse_bind(creature)
        self._skin = np.zeros((n, 4, 4))
        self._frame = 0
        #: The locomotion controller (``engine.gait.GaitController``), made by the first
        #: ``locomote`` call; None while the character has never been asked to move.
        self.gait = None
        # -- impact response (engine.response.impact) ------------------------------------
        self.response = None                    #: the ImpactResponse, made by the first hit
        # -- end impact response ---------------------------------------------------------
        #: Session recorders capturing after every tick (``record``).
        self.recorders: list = []

    # -- views into the stack ----------------------------------------------------------

    def _bind_views(self) -> None:
        s, r = self._stack, self._row
        self.player.arrays = s.player.rows(r, r + 1)
        self.world_positions = s.world_pos[r]      # (nbody, 3) world, m
        self.world_rotations = s.world_rot[r]      # (nbody, 4) world, w-first
        self.pose_positions = s.char_pos[r]        # (nbody, 3) character space
        self.pose_rotations = s.char_rot[r]
        self._prev_world_pos = s.prev_world_pos[r]   # impact response: last frame's pose
        self._prev_world_rot = s.prev_world_rot[r]
        # One-element views of each slot's clip time, made once (no slicing per frame).
        self._slot_time = [s.player.time[r, k : k + 1] for k in range(self.player.nslot)]

    def _move_to(self, stack: _Stack, row: int) -> None:
        stack.copy_row(row, self._stack, self._row)
        self._stack, self._row = stack, row
        self._bind_views()

    # -- placement and targets ---------------------------------------------------------

    def set_placement(self, position=None, heading: float | None = None, rotation=None, *,
                      teleport: bool = False) -> None:
        """Place the character frame in the world: ``position`` (3,), and a ``heading``
        (radians about +Z) or a full ``rotation`` quaternion. Moving the placement every
        frame moves the character (its passive bodies swing with the motion);
        ``teleport=True`` jumps without secondary motion."""
        s, r = self._stack, self._row
        if teleport:
            old_pos, old_rot = s.place_pos[r].copy(), s.place_rot[r].copy()
        if position is not None:
            p = np.asarray(position, dtype=float)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise ValueError(f"position must be 3 finite numbers, got {position!r}")
            s.place_pos[r] = p
        if heading is not None and rotation is not None:
            raise ValueError("give a heading or a rotation, not both")
        if heading is not None:
            if not math.isfinite(heading):
                raise ValueError(f"heading must be finite, got {heading!r}")
            s.place_rot[r] = (math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2))
        if rotation is not None:
            q = np.asarray(rotation, dtype=float)
            n = float(np.linalg.norm(q)) if q.shape == (4,) else 0.0
            if not (n > 1e-9 and np.isfinite(n)):
                raise ValueError(f"rotation must be a non-zero finite quaternion (w, x, y, z), got {rotation!r}")
            s.place_rot[r] = q / n
        if teleport:
            self._snap_world(old_pos, old_rot)

    def _snap_world(self, old_pos: np.ndarray, old_rot: np.ndarray) -> None:
        """The displayed pose carried rigidly from the placement (``old_pos``, ``old_rot``)
        to the current one; passive motion reset. Carried, not rebuilt from the
        character-space pose: passive bodies are posed in the world by the output stage
        and their character-space rows are stale (the impact response's stagger, placed on
        where it stepped to as it ended, showed random 31's jaw 0.68 rad off for a frame)."""
        s, r = self._stack, self._row
        n = self.creature.nbody
        delta = _qmul(s.place_rot[r], old_rot * np.array([1.0, -1.0, -1.0, -1.0]))
        d = np.repeat(delta[None], n, axis=0)
        rot = s.world_rot[r].copy()
        quat_mul_batch_into(d, rot, s.world_rot[r])
        rel = s.world_pos[r] - old_pos
        quat_rotate_batch_into(d, rel, s.world_pos[r])
        s.world_pos[r] += s.place_pos[r]
        s.jig_err[r] = 0.0
        s.jig_err_vel[r] = 0.0
        s.jig_active[r] = False
        s.jig_twist[r] = 0.0
        s.jig_contact[r] = (1.0, 0.0, 0.0, 0.0)
    @property
    def position(self) -> np.ndarray:
        return self._stack.place_pos[self._row].copy()

    @property
    def rotation(self) -> np.ndarray:
        return self._stack.place_rot[self._row].copy()

    def set_target(self, name: str, position) -> None:
        """Set (or move) the named external target, in world space."""
        p = np.asarray(position, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"target '{name}' must be 3 finite numbers, got {position!r}")
        self._targets[name] = p

    def clear_target(self, name: str) -> None:
        self._targets.pop(name, None)

    # -- locomotion ----------------------------------------------------------------------

    def locomote(self, velocity=(0.0, 0.0), turn_rate: float = 0.0) -> None:
        """Move under the gait system: ``velocity`` (forward, left) in m/s in the
        character's heading frame, ``turn_rate`` in rad/s about +Z (left positive). The
        command may change discontinuously from frame to frame (stop, reverse, turn)."""
        v = np.asarray(velocity, dtype=float)
        if v.shape != (2,) or not np.all(np.isfinite(v)) or not math.isfinite(turn_rate):
            raise ValueError(f"locomote: velocity must be 2 finite numbers and turn_rate finite, got "
                             f"{velocity!r}, {turn_rate!r}")
        self._ensure_gait().command(v, float(turn_rate))

    def set_terrain(self, height, normal=None) -> None:
        """The ground under the character: ``height(x, y) -> z`` in world space (and
        optionally ``normal(x, y) -> (3,)``); None for the flat plane z = 0."""
        self._ensure_gait().set_terrain(height, normal)

    def _ensure_gait(self):
        if self.gait is None:
            from engine.gait import GaitController

            self.gait = GaitController(self.creature)
            self._stack.stand[self._row] = False        # the controller plants the feet now
        return self.gait

    # -- playing -----------------------------------------------------------------------

    def binding(self, animation: Animation) -> Binding:
        """The (cached) binding of ``animation`` on this creature: its variants."""
        return bind(animation, self.creature)

    def play(self, animation: Animation, variant: int | str | Variant | None = None, weight: float = 1.0,
             fade: float = 0.2, loop: bool | None = None, *, speed: float = 1.0, layer: int = 0,
             fade_out: float | None = None, crossfade: bool = True,
             on_event: EventCallback | None = None, start_time: float = 0.0) -> PlayHandle:
        """Play ``animation`` (its ``variant``: index, id or Variant; default the first),
        from ``start_time`` seconds into the clip (0: its start; a game joining a clip
        mid-way, or a tool scrubbing)."""
        clip = self._clip(animation, variant)
        if not (isinstance(start_time, (int, float)) and math.isfinite(start_time)
                and 0.0 <= start_time <= animation.length):
            raise ValueError(f"start_time must be within the clip (0..{animation.length:g} s), got {start_time!r}")
        return self.player.play(animation, payload=clip, weight=weight, fade=fade, fade_out=fade_out, loop=loop,
                                speed=speed, layer=layer, crossfade=crossfade, on_event=on_event,
                                start_time=float(start_time))

    def queue(self, animation: Animation, variant=None, weight: float = 1.0, fade: float = 0.2,
              loop: bool | None = None, *, speed: float = 1.0, layer: int = 0, fade_out: float | None = None,
              on_event: EventCallback | None = None) -> PlayHandle:
        """Play ``animation`` when what plays on ``layer`` now ends."""
        clip = self._clip(animation, variant)
        return self.player.queue(animation, payload=clip, weight=weight, fade=fade, fade_out=fade_out, loop=loop,
                                 speed=speed, layer=layer, on_event=on_event)

    def stop(self, handle: PlayHandle | None = None, fade: float = 0.2) -> None:
        """Fade out one clip, or everything (``handle=None``)."""
        if handle is None:
            self.player.stop_all(fade)
        else:
            self.player.stop(handle, fade)

    def set_layer_weight(self, layer: int, weight: float) -> None:
        self.player.set_layer_weight(layer, weight)

    @property
    def on_event(self) -> EventCallback | None:
        return self.player.on_event

    @on_event.setter
    def on_event(self, callback: EventCallback | None) -> None:
        self.player.on_event = callback

    def _clip(self, animation: Animation, variant) -> _Clip:
        if not isinstance(animation, Animation):
            raise TypeError(f"play needs an Animation, got {type(animation).__name__}")
        binding = bind(animation, self.creature)
        return _Clip(animation, binding, binding.bound(variant))

    # -- one frame ---------------------------------------------------------------------

    def tick(self, dt: float) -> None:
        """Advance the character by ``dt`` seconds and pose every body."""
        _check_dt(dt)
        np.copyto(self._prev_world_pos, self.world_positions)   # impact response: the
        np.copyto(self._prev_world_rot, self.world_rotations)   # finite-difference velocity
        self._stack.last_dt = dt
        st = self.stages
        if st.player:
            self.player.advance(dt)                     # 1. player: clip times, fades, queue, events
        if st.sample:
            _sample_character(self)                     # 2-3. sample curves, specialize (S)
        if st.blend:
            _blend_stack(self._stack, self.player)      # 4. blend clips and layers into goals
        if st.gait:
            if self.gait is not None:
                _gait_character(self, dt)               # 5. gait: feet, hips, root motion
            else:
                _stand_rows(self._stack, _row(self._row))   # ... or standing: feet held on the ground
        _solve_character(self)                          # 6. IK (or the rest pose when off)
        if self.gait is not None:
            self.gait.observe(self._stack.char_pos[self._row], self._stack.char_rot[self._row])   # what the IK did
        if st.output:
            _output_stack(self._stack, self.jiggle_rig, dt, st.jiggle)   # 7-8. jiggle, world output
            if self._stack.xf_live:
                _blend_switches(self._stack, _row(self._row), dt, [self] if _handing_over(self) else ())
        if self.response is not None and self.response.phase != "idle":
            self.response.tick(dt)                      # 9. impact response (engine.response)
        if self.recorders:
            self._capture(dt)                           # 10. session recording (record)
        self._frame += 1
        if compiling.line_open:                         # the first run's compiling line ends here
            compiling.end_line()

    # -- impact response (engine.response.impact) ----------------------------------------

    def hit(self, body, impulse, point=None, duration: float = 0.0) -> None:
        """Hit ``body`` (name or index) with ``impulse`` (N s, world), at ``point`` (world;
        None: the body's centre), as a contact lasting ``duration`` s (0: instantaneous).
        The character is physical from this tick and re-enters animation by itself; a hit
        during a response re-plans from the current physical state."""
        if self.response is None:
            from engine.response.impact import ImpactResponse

            compiling.notice("physics")   # the first hit compiles the physics (once, when not cached)
            self.response = ImpactResponse(self)
        self.response.hit(body, impulse, point, duration)
        _REACTING.add(self)

    def prepare_impacts(self) -> float:
        """Make the impact response now (its motion library built or loaded from the disk
        cache, its kernels loaded), so the first ``hit`` does not pay for it inside a game
        frame; returns the seconds taken (``ImpactResponse.prepare``)."""
        if self.response is None:
            from engine.response.impact import ImpactResponse

            self.response = ImpactResponse(self)
        return self.response.prepare()

    @property
    def reacting(self) -> bool:
        """Whether an impact response is running (``response.phase``, ``response.clip``)."""
        return self.response is not None and self.response.phase != "idle"
    # -- end impact response -------------------------------------------------------------

    # -- session recording -------------------------------------------------------------

    def record(self, fps: float = 30.0):
        """Record what this character shows from now on (clips, gait, IK, jiggles, impact
        responses: the world pose after each tick, alone or in a ``Crowd``), for export::

            rec = char.record()             # the pose now is its first frame
            ...                             # the game ticks
            rec.stop()
            rec.save("session.glb")         # or .gltf, or .bvh

        Returns the ``engine.io.gltf_export.SessionRecorder``; its ``recording()`` is the
        motion resampled to ``fps`` keys. Several recorders may run at once."""
        from engine.io.gltf_export import SessionRecorder

        rec = SessionRecorder(self, fps=fps)
        rec.capture()
        rec.attached = True
        self.recorders.append(rec)
        _RECORDING.add(self)
        return rec

    def _capture(self, dt: float) -> None:
        for rec in self.recorders:
            rec.capture(dt)

    def _stop_recording(self, rec) -> None:
        if rec in self.recorders:
            self.recorders.remove(rec)
        if not self.recorders:
            _RECORDING.discard(self)

    # -- outputs -----------------------------------------------------------------------

    def skinning_matrices(self, out: np.ndarray | None = None) -> np.ndarray:
        """(nbody, 4, 4) world transform x inverse rest transform per body."""
        if out is None:
            out = self._skin
        RK.skinning_into(self.world_positions, self.world_rotations, self._inv_bind, out)
        return out

    def world_matrices(self) -> np.ndarray:
        """(nbody, 4, 4) world transform of every body."""
        return np.stack([_pose_matrix(p, q) for p, q in zip(self.world_positions, self.world_rotations,
                                                              strict=True)])

    @property
    def ik_plan(self):
        """The IK plan of what plays now (None before the first tick)."""
        return self._plan


# -- stage helpers (shared by Character and Crowd) -------------------------------------------


def _check_dt(dt: float) -> None:
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"tick: dt must be a positive finite number of seconds, got {dt!r}")


def _fill_external(char: Character, clip: _Clip, table_row: np.ndarray) -> None:
    """External target rows in character space (the game sets them in world space)."""
    if clip.n_ext == 0:
        return
    s, r = char._stack, char._row
    for k, name in enumerate(clip.bound.target_names):
        p = char._targets.get(name)
        if p is None:
            table_row[k] = default_target(clip.animation, char.creature, name)
        else:
            quat_rotate_inv_into(s.place_rot[r], p - s.place_pos[r], table_row[k])


def _sample_character(char: Character) -> None:
    for slot, h in enumerate(char.player.handles):
        if h is None:
            continue
        clip: _Clip = h.payload
        if clip.n_ext:
            _fill_external(char, clip, clip.table[0])
        clip.bound_call(char, slot).call()


def _blend_stack(s: _Stack, player: Player) -> None:
    if s.blend_call is None:
        c = s.creature
        a = s.player
        s.blend_call = BoundKernel(RK.blend_layers, (
            a.active, a.effective, a.layer, a.layer_weight.shape[1], s.sg_pos, s.sg_rot, s.sg_pw, s.sg_rw,
            c.body_rest_pos, c.body_rest_rot, s.lay_pos, s.lay_rot, s.lay_pw, s.lay_rw, s.goal_pos, s.goal_rot,
            s.goal_pw, s.goal_rw, s.root_pos, s.root_rot))
    s.blend_call.call()


def _gait_args(s: _Stack) -> tuple:
    """The character arrays the gait stage reads and writes (``engine.gait.gait_stage``);
    ``ground``: the terrain under the character, for the passive bodies."""
    if s.gait_args is None:
        s.gait_args = (s.place_pos, s.place_rot, s.root_pos, s.root_rot, s.goal_pos, s.goal_rot, s.goal_pw,
                       s.goal_rw, s.ground, s.ground_set)
    return s.gait_args


def _gait_character(char: Character, dt: float) -> None:
    s, r = char._stack, char._row
    g = char.gait
    hit = g._calls.get("char")
    if hit is None or hit[0] is not s or hit[1] is not g._gs or hit[3] is not _row(r):
        gs = g._gs
        rows, crows = _row(g._gr), _row(r)
        call = BoundKernel(SK.gait_rows, (float(dt), 0, rows, crows) + _gait_args(s) + gs.state_args + gs.rig_args,
                           slots=(0,))
        hit = g._calls["char"] = (s, gs, rows, crows, call)
    from engine.gait.controller import gait_stage

    gait_stage(dt, hit[1], hit[2], hit[3], _gait_args(s), hit[4])


class _GaitBatch:
    """The walking members of a crowd group: their controllers in one gait stack, stepped
    and observed by one kernel call each (``engine.gait._step_kernels``)."""

    def __init__(self, s: _Stack, walkers: list[Character]) -> None:
        from engine.gait.controller import GaitStack, gait_stage

        self.step = gait_stage
        self.stack = GaitStack([m.gait for m in walkers], private=False)
        self.rows = np.arange(len(walkers), dtype=np.int64)
        self.crows = np.array([m._row for m in walkers], np.int64)
        gs = self.stack
        self.call = BoundKernel(SK.gait_rows, (1.0 / 60.0, 0, self.rows, self.crows) + _gait_args(s) + gs.state_args
                                + gs.rig_args, slots=(0,))
        self.observe = BoundKernel(SK.observe_rows, (self.rows, self.crows, s.char_pos, s.char_rot) + gs.observe_args)


def _stand_rows(s: _Stack, rows: np.ndarray) -> None:
    """Standing feet for the stack rows ``rows`` that have no locomotion controller (the
    root's box first kept out of the ground, then the feet, then the goals)."""
    call = s.stand_call
    if call is None or call.args[0] is not rows:
        c = s.creature
        legs = _standing_legs(c)
        call = s.stand_call = BoundKernel(RK.stand_feet, (rows, s.stand, c.leg_foot, c.body_rest_pos, c.body_rest_rot,
                                                          s.goal_pos, s.goal_rot, s.goal_pw, s.goal_rw, s.root_pos,
                                                          s.root_rot) + legs + (_spine_carry(c), np.zeros((c.nleg, 8)),
                                                                                s.ground_set,
                                                                                np.ascontiguousarray(c.body_extent[0]),
                                                                                float(_body_floor(c)[0])))
    call.call()
    call = s.ground_call
    if call is None or call.args[0] is not rows:
        c = s.creature
        call = s.ground_call = BoundKernel(RK.goals_above_ground, (rows, s.ground_set, s.goal_pos, s.goal_rot,
                                                                   s.goal_pw, s.goal_rw, c.body_rest_rot,
                                                                   c.body_extent, _body_floor(c)))
    call.call()


def _body_floor(c: Creature) -> np.ndarray:
    """(nbody,) the lowest a goal may put each body's box corner, m: the ground, or lower
    where the body's box dips into it at rest (``RK.goals_above_ground``). Made once."""
    hit = _FLOORS.get(c)
    if hit is None:
        from engine.ik.plan import body_floor

        hit = _FLOORS[c] = body_floor(c)      # the same rule as the IK's ground constraint
    return hit


_FLOORS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _spine_carry(c: Creature) -> np.ndarray:
    """(nbody,) bool: the spine bodies but the root, whose goals the standing stage moves
    with the root (``RK.stand_feet``)."""
    out = np.array(c.body_is_spine, np.bool_)
    out[0] = False
    return out


def _standing_legs(c: Creature) -> tuple:
    """Per leg, for the standing stage (``RK.stand_feet``): knee-less or not (one segment
    from the hip to the foot: the leg's bodies are its root and its foot), the hip joint in
    the root's frame, the ankle in the foot's frame (from its origin), the hip-to-ankle
    length, the chain's length (hip to ankle along the joints; for a pivot foot, the
    segment plus the foot's reach to its contact point), and for a pivot foot (see
    ``engine.gait.rig``) its knee row (rest foot joint - rest origin, segment length; zero
    for every other foot) and its contact point from its origin, at rest in character space
    and in the foot's frame; the spine body the leg hangs from and the hip in its frame.
    Made once per creature."""
    hit = _LEGS.get(c)
    if hit is None:
        from engine.gait.rig import _pivot, contact_point
        from engine.mathx import quat_conj, quat_rotate

        n = c.nleg
        rigid = np.array([int(c.leg_body_num[k]) == 2 for k in range(n)], np.bool_)
        hip = np.zeros((n, 3))
        ankle = np.zeros((n, 3))
        reach = np.zeros(n)
        chain = np.zeros(n)
        knee = np.zeros((n, 4))
        contact = np.zeros((n, 3))
        contact_local = np.zeros((n, 3))
        for k in range(n):
            f = int(c.leg_foot[k])
            top = int(c.limb_root[c.body_limb[f]])
            hip[k] = c.body_rootrel_joint[top]
            ankle[k] = -c.body_joint_offset[f]
            reach[k] = float(np.linalg.norm(c.body_rootrel_joint[f] - c.body_rootrel_joint[top]))
            chain[k] = float(c.body_limb_length[f])
            contact[k] = contact_point(c, f) - c.body_rest_pos[f]
            contact_local[k] = quat_rotate(quat_conj(c.body_rest_rot[f]), contact[k])
            piv = _pivot(c, f, c.body_joint[top], reach[k]) if rigid[k] else None
            if piv is not None:
                knee[k, :3] = piv[0]
                knee[k, 3] = reach[k]
                chain[k] = reach[k] + float(np.linalg.norm(piv[1] - piv[0]))
        attach = np.array([int(c.body_spine_attach[int(c.leg_foot[k])]) for k in range(n)], np.int64)
        hip_local = np.array([quat_rotate(quat_conj(c.body_rest_rot[attach[k]]),
                                          c.body_joint[int(c.limb_root[c.body_limb[int(c.leg_foot[k])]])]
                                          - c.body_rest_pos[attach[k]]) for k in range(n)]).reshape(n, 3)
        hit = _LEGS[c] = (rigid, hip, ankle, reach, chain, knee, contact, contact_local, attach, hip_local)
    return hit


_LEGS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _update_plan(char: Character) -> None:
    """The IK plan for the bodies the playing clips pose (rebuilt only when what plays
    changes; plans themselves are cached per creature and goal set)."""
    key = char.player.version if char.gait is None else (char.player.version, char.gait.version)
    if key == char._plan_key and char._plan is not None:
        return
    goal_bodies = set()
    for h in char.player.handles:
        if h is not None:
            goal_bodies.update(int(b) for b in h.payload.bound.goal_bodies)
    if char.gait is not None:
        goal_bodies.update(int(b) for b in char.gait.goal_bodies)
    else:
        goal_bodies.update(int(b) for b in char.creature.leg_foot)     # standing feet
    goal_bodies.discard(0)
    plan = plan_for(char.creature, sorted(goal_bodies), char.ik_params)
    if plan is not char._plan:
        if char._plan is not None:
            char._stack.xf_pending[char._row] = True     # handed over from last frame's pose
            char._stack.xf_live = True
        char._plan = plan
        char._scratch_ik = plan.make_scratch()
        s, r = char._stack, char._row
        s.driven[r] = plan.has_ik
        s.driven[r, 0] = True
    char._plan_key = key


def _solve_character(char: Character) -> None:
    _update_plan(char)
    s, r = char._stack, char._row
    if char.stages.ik:
        call = char._solve_call
        if call is None or call.args[0] is not char._plan.blobs[0] or call.args[5] is not s.root_pos:
            b = char._plan.blobs
            call = char._solve_call = BoundKernel(RK.solve_indexed, (
                b[0], b[1], b[2], b[3], _row(r), s.root_pos, s.root_rot, s.goal_pos, s.goal_rot, s.goal_pw, s.goal_rw,
                s.char_pos, s.char_rot, char._scratch_ik, s.ik_bad, s.ground_set))
        call.call()
        if s.ik_bad[r] != -1:
            _raise_ik(char, int(s.ik_bad[r]))
    else:
        _rest_pose(char.creature, s.root_pos[r], s.root_rot[r], s.char_pos[r], s.char_rot[r], s.driven[r])


def _raise_ik(char: Character, code: int) -> None:
    from engine.ik.solver import _raise_bad

    _raise_bad(char._plan, code, who=f"character of creature '{char.creature.name}': ")


def _rest_pose(c: Creature, root_pos, root_rot, out_pos, out_rot, driven) -> None:
    """The root-relative rest pose carried by the root (the IK stage switched off)."""
    for b in np.flatnonzero(driven):
        out_rot[b] = _qmul(root_rot, c.body_rootrel_rot[b])
        out_pos[b] = root_pos + _qrot(root_rot, c.body_rootrel_pos[b])


def _output_stack(s: _Stack, rig: JiggleRig, dt: float, simulate: bool) -> None:
    if s.output_call is None:
        c = s.creature
        s.output_call = BoundKernel(RK.output_and_jiggle, (
            s.driven, s.place_pos, s.place_rot, s.char_pos, s.char_rot, s.world_pos, s.world_rot, c.body_parent,
            c.body_local_rot, c.body_local_joint, c.body_joint_offset, rig.lever, rig.omega, rig.zeta, rig.max_err,
            rig.sleep, rig.follow, c.body_extent, s.ground, s.ground_set, s.jig_err, s.jig_err_vel, s.jig_target,
            s.jig_target_vel, s.jig_active, s.jig_twist, s.jig_contact, s.jig_chain_joint, s.jig_chain_rot, 1.0 / 60.0,
            True), slots=(29, 30))
    s.output_call.call(float(dt), bool(simulate))


#: 1/s of the IK plan's hand-over (``_blend_switches``): the offset falls to 1% in about 0.4 s
#: and the pose changes fastest, omega / e of the offset a second, 0.07 s after the switch.
SWITCH_OMEGA = 16.0


def _handing_over(char: Character) -> bool:
    """An impact response places the pose itself (physical, or its hand-off's offset on
    the found clip): the plan's hand-over stays out of its way. Once the offset is gone (a
    stagger still to end, "settle") the clips drive the pose alone, and a plan switch there
    (the stagger fading out to nothing before what played before resumes: random 31's
    mouth turned 0.68 rad in that frame) is handed over like any other."""
    return char.response is not None and char.response.phase in ("burst", "transition", "blend")


def _blend_switches(s: _Stack, rows: np.ndarray, dt: float, reacting) -> None:
    """The IK plan's hand-over. A character's plan (which bodies the IK poses and which
    goals it reads) changes when a clip starts or ends, and a plan with a body's goals at
    weight zero does not pose the creature as the plan without them does: a body that
    enters the IK sub-tree, or a spine body that becomes a particle of its own, leaves the
    pose its parent carried it in for the solver's (random creature 24's head, 0.79 rad in
    the first frame of a crossfade from hold_platter into idle_breathe, which puts goals
    on the spine). So at a switch the pose shown last frame is kept as per-body offsets
    that decay (critically damped, ``SWITCH_OMEGA``; the impact response hands back the
    same way), in each body's parent frame so the chain stays joined (offsets per body in
    the world parted joints by 18% of a bone on captured skeletons in ``dance``), but for a
    planted foot's leg, which shows this frame's pose so the foot does not slide
    (``RK.switch_blend``). ``reacting``: characters an impact response is placing
    (``_handing_over``), skipped: the response hands over itself."""
    for m in reacting:
        s.xf_pending[m._row] = False
        s.xf_t[m._row] = -1.0
    if not s.xf_live:
        return
    c = s.creature
    live = RK.switch_blend(rows, s.xf_pending, s.xf_t, s.xf_pos, s.xf_rot, s.prev_world_pos, s.prev_world_rot,
                           s.world_pos, s.world_rot, c.body_parent, c.body_joint_offset, c.body_limb, s.xf_foot,
                           s.goal_pw, s.lay_rot, s.lay_pos, s.xf_hold, float(dt), SWITCH_OMEGA)
    s.xf_live = live or (rows.shape[0] < s.n and bool(np.any(s.xf_t >= 0.0) or np.any(s.xf_pending)))


#: Index arrays of one element, made once (row k of a stack), so the per-frame path
#: does not build arrays.
_ROW = [np.array([k], np.int64) for k in range(64)]


def _row(k: int) -> np.ndarray:
    """The one-element index array of row ``k`` (made once per row: a member of a crowd of
    thousands can be ticked alone too)."""
    while k >= len(_ROW):
        _ROW.append(np.array([len(_ROW)], np.int64))
    return _ROW[k]


def _qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _qrot(q, v):
    u = np.asarray(q[1:], dtype=float)
    t = 2.0 * np.cross(u, v)
    return np.asarray(v, dtype=float) + q[0] * t + np.cross(u, t)


def _inverse_bind(c: Creature) -> np.ndarray:
    """(nbody, 4, 4) inverse of each body's rest transform [R p; 0 1]: [R^T, -R^T p]
    (cached per creature: immutable, shared by every character of it)."""
    hit = _INV_BIND.get(c)
    if hit is None:
        R = quat_to_matrix_batch(c.body_rest_rot)
        hit = np.zeros((c.nbody, 4, 4))
        hit[:, :3, :3] = np.transpose(R, (0, 2, 1))
        hit[:, :3, 3] = -np.einsum("bji,bj->bi", R, c.body_rest_pos)
        hit[:, 3, 3] = 1.0
        hit.flags.writeable = False
        _INV_BIND[c] = hit
    return hit


_INV_BIND: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

#: Characters whose impact response runs (added by ``hit``, dropped when it ends), so a
#: crowd ticks responses without a loop over every member.
_REACTING: weakref.WeakSet = weakref.WeakSet()
#: Characters with a session recorder running (``Character.record``), for the same reason.
_RECORDING: weakref.WeakSet = weakref.WeakSet()


def quat_to_matrix_batch(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotation matrices of (n, 4) unit quaternions (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def _pose_matrix(pos, rot) -> np.ndarray:
    w, x, y, z = rot
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                 [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                 [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = pos
    return m


class Crowd:
    """Many characters ticked together: one kernel call per stage and creature (and per
    bound animation variant and IK plan), not one per character.

    The characters keep working alone too (their arrays become rows of the crowd's
    stacks); a character belongs to at most one crowd.
    """

    def __init__(self, characters) -> None:
        self.characters: list[Character] = list(characters)
        if not self.characters:
            raise ValueError("a Crowd needs at least one character")
        if len({id(c) for c in self.characters}) != len(self.characters):
            raise ValueError("a character appears twice in the crowd")
        self._groups: list[_Group] = []
        by_creature: dict[int, list[Character]] = {}
        for ch in self.characters:
            if not isinstance(ch, Character):
                raise TypeError(f"a Crowd holds Characters, got {type(ch).__name__}")
            by_creature.setdefault(id(ch.creature), []).append(ch)
        for members in by_creature.values():
            self._groups.append(_Group(members))

    def __len__(self) -> int:
        return len(self.characters)

    def tick(self, dt: float) -> None:
        """Advance every character by ``dt`` seconds."""
        _check_dt(dt)
        for g in self._groups:
            g.tick(dt)
        if compiling.line_open:
            compiling.end_line()


class _Group:
    """The characters of one creature in a crowd, in one stack."""

    def __init__(self, members: list[Character]) -> None:
        first = members[0]
        self.members = members
        self.creature = first.creature
        nslot, nlayer = first.player.nslot, first.player.nlayer
        for m in members:
            if (m.player.nslot, m.player.nlayer) != (nslot, nlayer):
                raise ValueError("characters of one creature in a crowd need the same slot and layer counts")
        self.stack = _Stack(self.creature, len(members), nslot, nlayer)
        for row, m in enumerate(members):
            m._move_to(self.stack, row)
        self._pairs: dict[int, _PairBuffer] = {}
        self._pairs_version = -1
        self._pair_list: list = []
        self._pair_cache: dict[int, tuple] = {}
        self._plans_version = -1
        self._plan_list: list = []
        self._events_version = -1
        self._events = np.zeros(0, np.int64)
        self._gait_epoch = -1
        self._gait: _GaitBatch | None = None
        self._events_seen = self._pairs_seen = self._plans_seen = (-1, -1)
        #: Whether this frame runs the big stages on all cores (``_ThreadChoice``).
        self._parallel = True
        self._threads = _ThreadChoice()

    def tick(self, dt: float) -> None:
        self._parallel = self._threads.choose()
        t0 = time.perf_counter()
        self._tick(dt)
        self._threads.record(self._parallel, time.perf_counter() - t0)

    def _tick(self, dt: float) -> None:
        s = self.stack
        ref = self.members[0]
        st = ref.stages
        np.copyto(s.prev_world_pos, s.world_pos)     # impact response: last frame's poses
        np.copyto(s.prev_world_rot, s.world_rot)
        s.last_dt = dt
        # 1. player: every clip slot of every member in one kernel
        if st.player:
            self._player(dt)
        # 2-3. sample + specialize: one kernel per bound variant over all pairs playing it
        if st.sample:
            self._sample()
        # 4. blend: one kernel over the stack
        if st.blend:
            _blend_stack(s, ref.player)
        # 5. gait: the members that locomote in one kernel (their controllers' state in one
        #    gait stack), the others stand, one kernel over the stack
        gait = self._gait_batch()
        if st.gait:
            if gait is not None:
                gait.step(dt, gait.stack, gait.rows, gait.crows, _gait_args(s), gait.call)
            _stand_rows(s, s.rows)
        # 6. IK: one kernel per IK plan over the members using it
        self._solve(st.ik)
        if gait is not None:
            gait.observe.call()      # what the IK made of the feet's goals
        # 7-8. jiggle and world output: one kernel over the stack
        if st.output:
            _output_stack(s, ref.jiggle_rig, dt, st.jiggle)
            if s.xf_live:
                _blend_switches(s, s.rows, dt, [m for m in _REACTING if m._stack is s and _handing_over(m)])
        # 9. impact response: only the members reacting, after the batched stages
        if _REACTING:
            for m in [m for m in _REACTING if m._stack is s]:
                m.response.tick(dt)
        # 10. session recording: only the members being recorded
        if _RECORDING:
            for m in [m for m in _RECORDING if m._stack is s]:
                m._capture(dt)

    def _player(self, dt: float) -> None:
        s = self.stack
        advance_arrays(s.player, dt)
        # Python only for members where something happened or where a clip's key may fire
        # (no loop over a thousand members per frame).
        rows = np.flatnonzero(s.player.flags.any(axis=1))
        event_rows = self._event_rows()
        if event_rows.shape[0]:
            rows = np.union1d(rows, self._event_hits(event_rows))
        for row in rows:
            self.members[row].player.after_advance()

    def _gait_batch(self) -> _GaitBatch | None:
        """The walking members' batch, re-gathered when a controller was made or moved."""
        if self._gait_epoch != SK.EPOCH[0]:
            walkers = [m for m in self.members if m.gait is not None]
            self._gait = _GaitBatch(self.stack, walkers) if walkers else None
            self._gait_epoch = SK.EPOCH[0]
        return self._gait

    def _changes(self) -> tuple[int, int]:
        """What the version sums below depend on: nothing changed since the last frame if
        no player changed its clips and no gait controller was made (then the sums over a
        thousand members are skipped)."""
        return _PLAYER_CHANGES[0], SK.EPOCH[0]

    def _event_rows(self) -> np.ndarray:
        """Rows of the members playing clips with key events (rebuilt when clips change)."""
        if self._changes() == self._events_seen:
            return self._events
        self._events_seen = self._changes()
        version = sum(m.player.version for m in self.members)
        if version != self._events_version:
            self._events = np.array([row for row, m in enumerate(self.members) if m.player.has_event_clips], np.int64)
            self._events_version = version
            # the key times of each slot's clip (NaN-padded) and the rows whose new clips
            # fire an event at their start time on their first frame
            times = [[sorted({e.t for ch in h.animation.channels for e in ch.events}) if h is not None else []
                      for h in self.members[row].player.handles] for row in self._events]
            width = max([len(t) for slots in times for t in slots], default=0)
            self._event_times = np.full((len(times), self.stack.player.time.shape[1], max(width, 1)), np.nan)
            for i, slots in enumerate(times):
                for k, t in enumerate(slots):
                    self._event_times[i, k, :len(t)] = t
            self._event_first = np.array([any(h is not None and getattr(h, "_events_from_start", False)
                                              for h in self.members[row].player.handles) for row in self._events],
                                         np.bool_)
        return self._events

    def _event_hits(self, rows: np.ndarray) -> np.ndarray:
        """The rows of ``rows`` (``_event_rows``) where a key may fire this frame: a key time
        within [prev, now] of a slot (both ends in, so never one too few; the player then
        decides exactly), or a clip's first frame; wraps and ends are flagged anyway."""
        a = self.stack.player
        t0 = a.prev_time[rows]
        t1 = a.time[rows]
        lo = np.minimum(t0, t1)[:, :, None]
        hi = np.maximum(t0, t1)[:, :, None]
        tab = self._event_times
        hit = ((tab >= lo) & (tab <= hi)).any(axis=(1, 2)) | self._event_first
        self._event_first[:] = False
        return rows[hit]

    def _pair_groups(self) -> list:
        """(buffer, first clip, pair count, members with external targets) per bound
        variant playing in the group, rebuilt only when a member's clips changed."""
        if self._changes() == self._pairs_seen:
            return self._pair_list
        self._pairs_seen = self._changes()
        version = sum(m.player.version for m in self.members)
        if version == self._pairs_version:
            return self._pair_list
        groups: dict[int, list] = {}
        for row, m in enumerate(self.members):
            for slot, h in enumerate(m.player.handles):
                if h is not None:
                    groups.setdefault(id(h.payload.bound), []).append((row, slot, h.payload, m))
        out = []
        nbody = self.creature.nbody
        # A bound variant whose pairs (member row, slot, clip) are those of the last build
        # keeps its views and bound kernels: a clip ending on one member rebuilds only its
        # own variant's entry (binding kernels costs tens of microseconds per argument).
        # The cache holds the clips, so the ids in a signature stay unique while cached.
        cache = {}
        for key, pairs in groups.items():
            sig = tuple((row, slot, id(clip)) for row, slot, clip, _ in pairs)
            old = self._pair_cache.get(key)
            if old is not None and old[0] == sig:
                cache[key] = old
                out.append(old[1])
                continue
            clip0: _Clip = pairs[0][2]
            buf = self._pairs.get(key)
            if buf is None or buf.capacity < len(pairs):
                buf = _PairBuffer(max(len(pairs), 2 * (buf.capacity if buf else 0)), clip0.n_ext + nbody)
                self._pairs[key] = buf
            for i, (row, slot, _, _) in enumerate(pairs):
                buf.pair_char[i] = row
                buf.pair_slot[i] = slot
            external = [(i, clip, m) for i, (_, _, clip, m) in enumerate(pairs) if clip.n_ext]
            k = len(pairs)
            # Many pairs are sampled on all cores, one scratch per chunk of pairs.
            chunks = _parallel_chunks(k)
            scratches = None
            if chunks > 1:
                if buf.scratches is None or buf.scratches.work33.shape[0] != chunks:
                    buf.scratches = make_scratches(clip0.animation, clip0.bound, chunks)
                scratches = buf.scratches
            # Views and kernel calls bound to them (engine._fastcall) made once per change,
            # not per frame.
            pair_char, pair_slot, times, tables = buf.pair_char[:k], buf.pair_slot[:k], buf.times[:k], buf.tables[:k]
            s, c, bv = self.stack, self.creature, clip0.bound
            gather = BoundKernel(RK.gather_times, (s.player.time, pair_char, pair_slot, times))
            args = [clip0.animation.curves, bv.slots, bv.slot_pos_on, bv.slot_rot_on, tables, times, pair_char,
                    pair_slot, c.body_rest_pos, c.body_rest_rot, clip0.scratch, s.sg_pos, s.sg_rot, s.sg_pw, s.sg_rw,
                    clip0.n_ext, c.body_parent, c.body_local_pos, c.body_local_rot, clip0.body_targets]
            serial = BoundKernel(RK.goals_pairs, tuple(args))
            parallel = None
            if scratches is not None:
                args[10] = scratches
                parallel = BoundKernel(RK.goals_pairs_parallel, tuple(args))
            entry = (gather, serial, parallel, tables, external)
            cache[key] = (sig, entry, pairs)
            out.append(entry)
        self._pair_cache = cache
        self._pair_list, self._pairs_version = out, version
        return out

    def _sample(self) -> None:
        for gather, serial, parallel, tables, external in self._pair_groups():
            gather.call()
            for i, clip, m in external:
                _fill_external(m, clip, tables[i])
            if parallel is not None and self._parallel:
                with numba.parallel_chunksize(1):   # chunks handed out as threads free up
                    parallel.call()
            else:
                serial.call()

    def _plan_groups(self) -> list:
        """(plan, scratch, row indices) per IK plan in use, rebuilt only on change."""
        if self._changes() == self._plans_seen:
            return self._plan_list
        self._plans_seen = self._changes()
        version = sum(m.player.version + (0 if m.gait is None else m.gait.version) for m in self.members)
        if version == self._plans_version:
            return self._plan_list
        plans: dict[int, tuple] = {}
        for row, m in enumerate(self.members):
            _update_plan(m)
            entry = plans.get(id(m._plan))
            if entry is None:
                plans[id(m._plan)] = (m._plan, m._scratch_ik, [row])
            else:
                entry[2].append(row)
        out = []
        for plan, scratch, rows in plans.values():
            idx = np.array(rows, np.int64)
            # Big groups are solved on all cores, one scratch per chunk of rows.
            chunks = _parallel_chunks(len(rows))
            scratches = np.zeros((chunks,) + plan.scratch_shape) if chunks > 1 else None
            out.append((plan, scratch, idx, scratches))
        self._plan_list = out
        self._plans_version = version
        return self._plan_list

    def _solve(self, ik_on: bool) -> None:
        s = self.stack
        for plan, scratch, idx, scratches in self._plan_groups():
            if ik_on:
                b = plan.blobs
                if scratches is None or not self._parallel:
                    nbad = RK.solve_indexed(b[0], b[1], b[2], b[3], idx, s.root_pos, s.root_rot, s.goal_pos,
                                            s.goal_rot, s.goal_pw, s.goal_rw, s.char_pos, s.char_rot, scratch,
                                            s.ik_bad, s.ground_set)
                else:
                    with numba.parallel_chunksize(1):   # chunks handed out as threads free up
                        nbad = RK.solve_indexed_parallel(b[0], b[1], b[2], b[3], idx, s.root_pos, s.root_rot,
                                                         s.goal_pos, s.goal_rot, s.goal_pw, s.goal_rw, s.char_pos,
                                                         s.char_rot, scratches, s.ik_bad, s.ground_set)
                if nbad:
                    row = int(idx[np.flatnonzero(s.ik_bad[idx] != -1)[0]])
                    _raise_ik(self.members[row], int(s.ik_bad[row]))
            else:
                for row in idx:
                    _rest_pose(self.creature, s.root_pos[row], s.root_rot[row], s.char_pos[row], s.char_rot[row],
                               s.driven[row])


#: Below this many rows (characters sharing an IK plan, or pairs playing one bound
#: variant) a crowd runs a stage on one thread. Measured (median crowd tick, us per
#: character, 2 threads, load ~1.5): 4 rows 20.4 parallel / 22.0 serial, 8: 15.3 / 18.8,
#: 16: 14.0 / 17.1, 64: 10.2 / 16.2, 256: 8.9 / 15.8. Small groups gain little and lose
#: most when a core is busy elsewhere (a region then waits for a descheduled thread).
PARALLEL_MIN_ROWS = 16


def _parallel_chunks(nrow: int) -> int:
    """How many chunks (each with its own scratch) ``nrow`` rows of a stage are cut into:
    1 (serial) for small groups, else several per thread, handed out as threads free up
    so a core busy with something else does not hold up the frame."""
    if nrow < PARALLEL_MIN_ROWS or numba.get_num_threads() < 2:
        return 1
    return max(1, min(nrow, 8 * numba.get_num_threads()))


class _ThreadChoice:
    """Serial or parallel, by measuring: a crowd group's big stages run on all cores only
    while that makes its frames faster. The first frames alternate the two (``PROBE``
    frames each) and the faster median wins; the choice is measured again every
    ``REPROBE`` frames (the load of the machine changes), and a parallel frame that takes
    more than ``LATE`` times the serial median (a thread descheduled: a core busy
    elsewhere) falls back to serial at once. Both paths give the same poses, bit for bit
    (the same kernels on the same rows), so switching never shows."""

    PROBE = 4
    REPROBE = 600
    LATE = 1.5

    __slots__ = ("serial", "parallel", "mode", "frame")

    def __init__(self) -> None:
        self.serial: list[float] = []
        self.parallel: list[float] = []
        self.mode: bool | None = None       # None while probing
        self.frame = 0

    def choose(self) -> bool:
        if numba.get_num_threads() < 2:
            return False
        self.frame += 1
        if self.mode is not None and self.frame % self.REPROBE == 0:
            self.mode = None
            self.serial.clear()
            self.parallel.clear()
        if self.mode is None:
            return len(self.parallel) <= len(self.serial)     # alternate, parallel first
        return self.mode

    def record(self, parallel: bool, seconds: float) -> None:
        if numba.get_num_threads() < 2:
            return
        if self.mode is None:
            (self.parallel if parallel else self.serial).append(seconds)
            if len(self.serial) >= self.PROBE and len(self.parallel) >= self.PROBE:
                # the first frame of each may still fill caches: compare the rest
                self.mode = bool(np.median(self.parallel[1:]) < np.median(self.serial[1:]))
        elif parallel and self.serial and seconds > self.LATE * float(np.median(self.serial[1:] or self.serial)):
            self.mode = False


class _PairBuffer:
    def __init__(self, capacity: int, nrow: int) -> None:
        self.capacity = capacity
        self.pair_char = np.zeros(capacity, np.int64)
        self.pair_slot = np.zeros(capacity, np.int64)
        self.times = np.zeros(capacity)
        self.tables = np.zeros((capacity, nrow, 3))
        self.scratches = None   # EvalScratch stacked per chunk, when sampled in parallel


__all__ = ["Character", "Crowd", "STAGES", "Stages", "MenagerieError"]
