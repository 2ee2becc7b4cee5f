"""PhysicsModel: the immutable rigid-body model of one or more characters (like mjModel).

Built once from Creatures (``model_from_creatures``) or from plain body specs
(``build_model``, used by the motion-capture tracker). Every body is a sphere, a capsule
or a box whose centre is the body origin (its centre of mass) and whose axes are the
body frame, so the physics body frame *is* the creature body frame and transforms read
back unchanged. Mass comes from density and volume (or an override), the inertia tensor
is diagonal in the body frame. Bodies are articulated by ball-and-socket joints at the
creature's joint points; a joint can be locked (all rotation fixed at its rest relative
rotation: the zombie's stiff knee of Wilke & Semwal section 2.2).

Array fields (read-only; n = nbody, j = njoint, f = nfeature, p = npair):
    body_shape (n,) int32          SHAPE_SPHERE, SHAPE_CAPSULE or SHAPE_BOX
    body_size (n, 3) float64       sphere (r, 0, 0); capsule (r, half length of the
                                   cylinder, axis 0/1/2); box half-extents, m
    body_mass (n,), body_inv_mass (n,) float64            kg, 1/kg (0: fixed body)
    body_inertia (n, 3), body_inv_inertia (n, 3) float64   principal moments, kg m^2
    body_character (n,) int32      which character a body belongs to
    body_contact_kind (n,) int32   KIND_NONE, KIND_GROUND or KIND_FOOT (the paper's
                                   foot handler: penalty + Coulomb + spin friction)
    body_rest_pos (n, 3), body_rest_rot (n, 4)            the rest pose (world)
    body_bound_radius (n,) float64 radius of a sphere around the body's centre, m
    body_seg_a, body_seg_b (n, 3), body_seg_radius (n,)   capsule used against other
                                   characters (a box uses its inscribed capsule)
    body_joint (n,) int32          the joint whose child is the body, -1 for roots
    joint_parent, joint_child (j,) int32
    joint_anchor_parent, joint_anchor_child (j, 3) float64  joint point in each body frame
    joint_rest_rot (j, 4) float64  child rotation relative to the parent at rest
    joint_locked (j,) int32        1: all relative rotation fixed at rest
    joint_servo_hz, joint_servo_zeta (j,) float64  default PD servo gains (0 Hz: passive)
    feat_body (f,) int32, feat_local (f, 3), feat_radius (f,), feat_spin_radius (f,)
                                   ground contact features: capsule end spheres, box
                                   corners, the sphere itself
    pair_a, pair_b (p,) int32      body pairs of different characters that collide
    terrain: ``Terrain``           the ground height function
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from engine.errors import DataError, MenagerieError
from engine.physics import _kernels as K

SHAPE_SPHERE, SHAPE_CAPSULE, SHAPE_BOX = 0, 1, 2
SHAPES = {"sphere": SHAPE_SPHERE, "capsule": SHAPE_CAPSULE, "box": SHAPE_BOX}
KINDS = {"none": K.KIND_NONE, "ground": K.KIND_GROUND, "foot": K.KIND_FOOT}


class PhysicsError(DataError):
    """A physics model or state that cannot be built from the given input."""


class SimulationDiverged(MenagerieError):
    """The simulation produced a non-finite state (reported, never hidden)."""


# ---------------------------------------------------------------------------------------
# Settings people can reason about, defaults in one place (like b2DefaultBodyDef)
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ContactSettings:
    """A contact's spring as a frequency (Hz) and damping ratio, mass-normalized by the
    contact's effective mass; Coulomb friction ``mu``; rotational friction ``spin_mu``
    (torque about the normal <= spin_mu * contact radius * normal force)."""

    hz: float = 60.0
    zeta: float = 1.0
    mu: float = 0.8
    spin_mu: float = 0.0


# Zordan et al. 2005 section 5: ground friction 1.0 for feet (0.5 lets them slip), and
# rotational friction that stops a planted foot spinning freely.
DEFAULT_FOOT = ContactSettings(hz=60.0, zeta=1.0, mu=1.0, spin_mu=0.5)
DEFAULT_GROUND = ContactSettings(hz=60.0, zeta=1.0, mu=0.8, spin_mu=0.0)
# "some compliance in the characters' interactions with each other" (section 5)
DEFAULT_PAIR = ContactSettings(hz=30.0, zeta=1.0, mu=0.5, spin_mu=0.0)


@dataclass(frozen=True)
class WorldSettings:
    """Everything global. ``joint_hz`` 0 means the stiffest stable joint spring (a
    quarter of the substep rate); ``max_push`` caps the speed (m/s) at which overlaps are
    pushed apart; ``margin`` is the speculative contact distance (m) on top of what the
    bodies can travel in a substep. ``solver`` 'direct' solves the ball joints exactly on
    the body-joint tree each pass (Baraff 1996; any mass ratio), 'gauss-seidel' with
    sequential impulses like the other constraints (cheaper, drifts O(h^2) with large
    mass ratios). ``servo_anchor`` (direct solver): a foot the ground pushed in the last
    substep counts as immovable in the servos' inertia, so a stance leg's servos are as
    stiff, in Hz, against the body they hold up as a free limb's against the limb (the
    outboard inertia of a knee is the shin's, and a thin leg under a heavy body held it up
    like a whisker: a bat's pose collapsed in 0.3 s at 5 Hz)."""

    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    foot: ContactSettings = DEFAULT_FOOT
    ground: ContactSettings = DEFAULT_GROUND
    pair: ContactSettings = DEFAULT_PAIR
    joint_hz: float = 0.0
    joint_zeta: float = 1.0
    max_push: float = 3.0
    margin: float = 0.01
    solver: str = "direct"
    servo_anchor: bool = False


# ---------------------------------------------------------------------------------------
# Terrain
# ---------------------------------------------------------------------------------------


class Terrain:
    """The ground as a height function z = H(x, y), stored as a grid sampled once (so
    kernels never call back into Python) and read bilinearly, clamped at the edges.
    ``Terrain.flat(z)`` is the plane z = const."""

    def __init__(self, height: np.ndarray, x0: float = 0.0, y0: float = 0.0, cell: float = 1.0) -> None:
        height = np.ascontiguousarray(height, dtype=np.float64)
        if height.ndim != 2 or height.shape[0] < 1 or height.shape[1] < 1:
            raise PhysicsError(f"terrain height grid must be 2-D and non-empty, got shape {height.shape}",
                               field="height", kind="terrain", subject="ground")
        if not np.all(np.isfinite(height)):
            raise PhysicsError("terrain height grid has non-finite values", field="height",
                               kind="terrain", subject="ground")
        if not (math.isfinite(cell) and cell > 0):
            raise PhysicsError(f"terrain cell size must be > 0, got {cell}", field="cell",
                               kind="terrain", subject="ground")
        height.flags.writeable = False
        self.height = height
        self.x0, self.y0, self.cell = float(x0), float(y0), float(cell)

    @classmethod
    def flat(cls, z: float = 0.0) -> Terrain:
        return cls(np.full((1, 1), float(z)))

    @classmethod
    def from_function(cls, func, xmin: float, xmax: float, ymin: float, ymax: float,
                      cell: float = 0.05) -> Terrain:
        """Sample ``func(x, y) -> z`` (numpy-vectorized or scalar) on a grid."""
        if not (xmax > xmin and ymax > ymin and cell > 0):
            raise PhysicsError("terrain bounds must have xmax > xmin, ymax > ymin and cell > 0",
                               kind="terrain", subject="ground", field="bounds")
        nx = int(math.ceil((xmax - xmin) / cell)) + 1
        ny = int(math.ceil((ymax - ymin) / cell)) + 1
        xs = xmin + cell * np.arange(nx)
        ys = ymin + cell * np.arange(ny)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        try:
            Z = np.broadcast_to(np.asarray(func(X, Y), dtype=np.float64), X.shape)
        except (TypeError, ValueError):
            Z = np.array([[float(func(x, y)) for y in ys] for x in xs])
        return cls(Z, xmin, ymin, cell)

    def sample(self, x: float, y: float) -> tuple[float, np.ndarray]:
        """Height and unit normal at (x, y)."""
        h, nx, ny, nz = K.terrain_sample(self.height, self.x0, self.y0, self.cell, float(x), float(y))
        return h, np.array([nx, ny, nz])


# ---------------------------------------------------------------------------------------
# Body specs (the "raw" input of the builder)
# ---------------------------------------------------------------------------------------


@dataclass
class BodySpec:
    """One rigid body for ``build_model``. ``pos``/``rot`` give its rest pose (world).
    A joint to ``parent`` (an index into the spec list, -1 for none) sits at the world
    point ``joint`` of the rest pose. ``servo_hz``/``servo_zeta`` are the default PD servo
    gains of that joint (0 Hz: passive), copied into every new PhysicsState."""

    name: str
    shape: str
    pos: np.ndarray
    rot: np.ndarray
    radius: float = 0.0
    half_length: float = 0.0
    axis: int = 2
    half_extents: np.ndarray | None = None
    density: float = 1000.0
    mass: float | None = None
    parent: int = -1
    joint: np.ndarray | None = None
    locked: bool = False
    contact: str = "ground"
    fixed: bool = False
    character: int = 0
    servo_hz: float = 0.0
    servo_zeta: float = 1.0


def shape_mass_inertia(shape: int, size: np.ndarray, density: float) -> tuple[float, np.ndarray]:
    """Mass (kg) and principal inertia (kg m^2, body frame) of a solid shape.

    Sphere: m = rho 4/3 pi r^3, I = 2/5 m r^2. Box (half-extents a, b, c):
    m = 8 rho a b c, I_x = m (b^2 + c^2) / 3. Capsule of radius r and cylinder length
    H = 2 * half_length along its axis: a cylinder (m_c = rho pi r^2 H) plus two
    hemispheres (m_h = rho 2/3 pi r^3 each); about the axis I = m_c r^2/2 + 2 m_h 2r^2/5;
    across it I = m_c (H^2/12 + r^2/4) + 2 m_h (2r^2/5 + H^2/4 + 3Hr/8) (hemisphere
    about its own centre of mass moved by the parallel-axis theorem).
    """
    if shape == SHAPE_SPHERE:
        r = size[0]
        mass = density * 4.0 / 3.0 * math.pi * r**3
        return mass, np.full(3, 0.4 * mass * r * r)
    if shape == SHAPE_BOX:
        a, b, c = size
        mass = 8.0 * density * a * b * c
        return mass, np.array([(b * b + c * c), (a * a + c * c), (a * a + b * b)]) * mass / 3.0
    r, hl, axis = size[0], size[1], int(size[2])
    H = 2.0 * hl
    mc = density * math.pi * r * r * H
    mh = density * 2.0 / 3.0 * math.pi * r**3
    i_axis = mc * r * r / 2.0 + 2.0 * mh * 0.4 * r * r
    i_across = mc * (H * H / 12.0 + r * r / 4.0) + 2.0 * mh * (0.4 * r * r + H * H / 4.0 + 3.0 * H * r / 8.0)
    inertia = np.full(3, i_across)
    inertia[axis] = i_axis
    return mc + 2.0 * mh, inertia


def _quat_conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _quat_rotate(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


class ModelArrays(NamedTuple):
    """What the kernels see of a PhysicsModel (see the module docstring)."""

    body_inv_mass: np.ndarray
    body_inertia: np.ndarray
    body_inv_inertia: np.ndarray
    body_contact_kind: np.ndarray
    body_bound_radius: np.ndarray
    body_seg_a: np.ndarray
    body_seg_b: np.ndarray
    body_seg_radius: np.ndarray
    joint_parent: np.ndarray
    joint_child: np.ndarray
    joint_anchor_parent: np.ndarray
    joint_anchor_child: np.ndarray
    joint_rest_rot: np.ndarray
    joint_locked: np.ndarray
    feat_body: np.ndarray
    feat_local: np.ndarray
    feat_radius: np.ndarray
    feat_spin_radius: np.ndarray
    pair_a: np.ndarray
    pair_b: np.ndarray
    body_joint: np.ndarray
    node_order: np.ndarray
    node_parent: np.ndarray
    terrain_height: np.ndarray
    params: np.ndarray


class PhysicsModel:
    """Immutable rigid-body model; see the module docstring for the arrays."""

    _frozen = False

    def __init__(self, *, body_names, joint_names, arrays: dict, terrain: Terrain,
                 settings: WorldSettings, characters: list[tuple[int, int]]) -> None:
        self.body_names = tuple(body_names)
        self.joint_names = tuple(joint_names)
        self.terrain = terrain
        self.settings = settings
        self.characters = tuple(characters)
        self._index = {n: i for i, n in enumerate(self.body_names)}
        for key, value in arrays.items():
            value = np.ascontiguousarray(value)
            value.flags.writeable = False
            object.__setattr__(self, key, value)
        s = settings
        params = np.zeros(K.NPARAM)
        params[K.P_GRAVITY_X:K.P_GRAVITY_Z + 1] = s.gravity
        params[[K.P_FOOT_HZ, K.P_FOOT_ZETA, K.P_FOOT_MU, K.P_FOOT_SPIN_MU]] = (
            s.foot.hz, s.foot.zeta, s.foot.mu, s.foot.spin_mu)
        params[[K.P_GROUND_HZ, K.P_GROUND_ZETA, K.P_GROUND_MU, K.P_GROUND_SPIN_MU]] = (
            s.ground.hz, s.ground.zeta, s.ground.mu, s.ground.spin_mu)
        params[[K.P_PAIR_HZ, K.P_PAIR_ZETA, K.P_PAIR_MU]] = (s.pair.hz, s.pair.zeta, s.pair.mu)
        params[K.P_JOINT_HZ], params[K.P_JOINT_ZETA] = s.joint_hz, s.joint_zeta
        params[K.P_MAX_PUSH], params[K.P_MARGIN] = s.max_push, s.margin
        params[[K.P_TERRAIN_X0, K.P_TERRAIN_Y0, K.P_TERRAIN_CELL]] = (terrain.x0, terrain.y0, terrain.cell)
        if s.solver not in ("direct", "gauss-seidel"):
            raise PhysicsError(f"solver must be 'direct' or 'gauss-seidel', got '{s.solver}'", field="solver",
                               kind="settings", subject="world")
        params[K.P_SOLVER] = 1.0 if s.solver == "direct" else 0.0
        params[K.P_SERVO_ANCHOR] = {False: 0.0, True: 1.0, "feet": 1.0, "any": 2.0}[s.servo_anchor]
        params.flags.writeable = False
        object.__setattr__(self, "params", params)
        object.__setattr__(self, "arrays", ModelArrays(
            **{name: (terrain.height if name == "terrain_height" else getattr(self, name))
               for name in ModelArrays._fields}))
        self._frozen = True

    def __setattr__(self, key, value):
        if self._frozen:
            raise AttributeError(f"PhysicsModel is immutable (tried to set '{key}')")
        object.__setattr__(self, key, value)

    @property
    def nbody(self) -> int:
        return len(self.body_names)

    @property
    def njoint(self) -> int:
        return int(self.joint_parent.shape[0])

    def body(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"physics model has no body '{name}'") from None

    @property
    def total_mass(self) -> float:
        return float(self.body_mass.sum())


def _check_vec(v, n, what, name):
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise PhysicsError(f"{what} must be {n} finite numbers, got {v!r}", subject=name, field=what)
    return a


def build_model(specs: list[BodySpec], *, terrain: Terrain | None = None,
                settings: WorldSettings | None = None, collide_characters: bool = True) -> PhysicsModel:
    """Validate body specs and build the immutable model. Bodies must come parents
    first (``parent < index``). Errors name the body and field at fault."""
    settings = settings or WorldSettings()
    terrain = terrain or Terrain.flat(0.0)
    n = len(specs)
    if n == 0:
        raise PhysicsError("a physics model needs at least one body", field="bodies")
    names = [sp.name for sp in specs]
    if len(set(names)) != n:
        dup = sorted({x for x in names if names.count(x) > 1})
        raise PhysicsError(f"body names must be unique; repeated: {', '.join(dup)}", field="name", subject=dup[0])
    shape = np.zeros(n, np.int32)
    size = np.zeros((n, 3))
    mass = np.zeros(n)
    inertia = np.zeros((n, 3))
    rest_pos = np.zeros((n, 3))
    rest_rot = np.zeros((n, 4))
    character = np.zeros(n, np.int32)
    kind = np.zeros(n, np.int32)
    fixed = np.zeros(n, bool)
    bound = np.zeros(n)
    seg_a = np.zeros((n, 3))
    seg_b = np.zeros((n, 3))
    seg_r = np.zeros(n)
    body_joint = np.full(n, -1, np.int32)
    j_parent, j_child, j_ap, j_ac, j_rest, j_locked, j_names = [], [], [], [], [], [], []
    j_servo = []
    f_body, f_local, f_rad, f_spin = [], [], [], []
    for i, sp in enumerate(specs):
        if sp.shape not in SHAPES:
            raise PhysicsError(f"unknown shape '{sp.shape}' (known: {', '.join(SHAPES)})", subject=sp.name,
                               field="shape")
        shape[i] = SHAPES[sp.shape]
        rest_pos[i] = _check_vec(sp.pos, 3, "pos", sp.name)
        q = _check_vec(sp.rot, 4, "rot", sp.name)
        nq = np.linalg.norm(q)
        if abs(nq - 1.0) > 1e-6:
            raise PhysicsError(f"rot must be a unit quaternion (|q| = {nq:.6g})", subject=sp.name, field="rot")
        rest_rot[i] = q / nq
        if sp.contact not in KINDS:
            raise PhysicsError(f"unknown contact kind '{sp.contact}' (known: {', '.join(KINDS)})",
                               subject=sp.name, field="contact")
        kind[i] = KINDS[sp.contact]
        character[i] = sp.character
        fixed[i] = sp.fixed
        if shape[i] == SHAPE_BOX:
            he = _check_vec(sp.half_extents if sp.half_extents is not None else [0, 0, 0], 3, "half_extents", sp.name)
            if np.any(he <= 0):
                raise PhysicsError(f"box half_extents must be > 0, got {he.tolist()}", subject=sp.name,
                                   field="half_extents")
            size[i] = he
        else:
            if not (math.isfinite(sp.radius) and sp.radius > 0):
                raise PhysicsError(f"radius must be > 0, got {sp.radius}", subject=sp.name, field="radius")
            if shape[i] == SHAPE_CAPSULE:
                if not (math.isfinite(sp.half_length) and sp.half_length >= 0):
                    raise PhysicsError(f"half_length must be >= 0, got {sp.half_length}", subject=sp.name,
                                       field="half_length")
                if sp.axis not in (0, 1, 2):
                    raise PhysicsError(f"axis must be 0, 1 or 2, got {sp.axis}", subject=sp.name, field="axis")
                size[i] = (sp.radius, sp.half_length, sp.axis)
            else:
                size[i] = (sp.radius, 0.0, 0.0)
        if not (math.isfinite(sp.density) and sp.density > 0):
            raise PhysicsError(f"density must be > 0, got {sp.density}", subject=sp.name, field="density")
        m0, i0 = shape_mass_inertia(int(shape[i]), size[i], sp.density)
        if sp.mass is not None:
            if not (math.isfinite(sp.mass) and sp.mass > 0):
                raise PhysicsError(f"mass must be > 0, got {sp.mass}", subject=sp.name, field="mass")
            i0 = i0 * (sp.mass / m0)
            m0 = float(sp.mass)
        mass[i] = m0
        inertia[i] = i0
        # contact geometry
        if shape[i] == SHAPE_SPHERE:
            r = size[i, 0]
            feats = [(np.zeros(3), r, r)]
            bound[i] = r
            seg_r[i] = r
        elif shape[i] == SHAPE_CAPSULE:
            r, hl, ax = size[i, 0], size[i, 1], int(size[i, 2])
            e = np.zeros(3)
            e[ax] = hl
            feats = [(-e, r, r), (e, r, r)] if hl > 0 else [(np.zeros(3), r, r)]
            bound[i] = hl + r
            seg_a[i], seg_b[i], seg_r[i] = -e, e, r
        else:
            he = size[i]
            corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * he
            spin_r = 0.5 * float(np.min(he))
            feats = [(c, 0.0, spin_r) for c in corners]
            bound[i] = float(np.linalg.norm(he))
            ax = int(np.argmax(he))
            r = float(np.min(np.delete(he, ax)))
            e = np.zeros(3)
            e[ax] = max(he[ax] - r, 0.0)
            seg_a[i], seg_b[i], seg_r[i] = -e, e, r
        if kind[i] != K.KIND_NONE and not fixed[i]:
            for local, r, spin_r in feats:
                f_body.append(i)
                f_local.append(local)
                f_rad.append(r)
                f_spin.append(spin_r)
        # joint to the parent
        if sp.parent >= 0:
            if sp.parent >= i:
                raise PhysicsError(f"parent index {sp.parent} must come before the body (index {i})",
                                   subject=sp.name, field="parent")
            if sp.joint is None:
                raise PhysicsError("a body with a parent needs a joint point", subject=sp.name, field="joint")
            jp = _check_vec(sp.joint, 3, "joint", sp.name)
            pa = specs[sp.parent]
            qa = rest_rot[sp.parent]
            body_joint[i] = len(j_parent)
            j_parent.append(sp.parent)
            j_child.append(i)
            j_ap.append(_quat_rotate(_quat_conj(qa), jp - rest_pos[sp.parent]))
            j_ac.append(_quat_rotate(_quat_conj(rest_rot[i]), jp - rest_pos[i]))
            j_rest.append(_quat_mul(_quat_conj(qa), rest_rot[i]))
            j_locked.append(1 if sp.locked else 0)
            j_names.append(sp.name)
            if not (math.isfinite(sp.servo_hz) and sp.servo_hz >= 0):
                raise PhysicsError(f"servo_hz must be >= 0, got {sp.servo_hz}", subject=sp.name, field="servo_hz")
            if not (math.isfinite(sp.servo_zeta) and sp.servo_zeta >= 0):
                raise PhysicsError(f"servo_zeta must be >= 0, got {sp.servo_zeta}", subject=sp.name,
                                   field="servo_zeta")
            j_servo.append((sp.servo_hz, sp.servo_zeta))
            if specs[sp.parent].character != sp.character:
                raise PhysicsError(f"joint to '{pa.name}' crosses characters", subject=sp.name, field="parent")
        elif sp.locked:
            raise PhysicsError("only a body with a parent joint can be locked", subject=sp.name, field="locked")
    inv_mass = np.where(fixed, 0.0, 1.0 / mass)
    inv_inertia = np.where(fixed[:, None], 0.0, 1.0 / inertia)
    pairs_a, pairs_b = [], []
    if collide_characters:
        for a in range(n):
            for b in range(a + 1, n):
                if character[a] != character[b] and not (fixed[a] and fixed[b]):
                    pairs_a.append(a)
                    pairs_b.append(b)
    nj = len(j_parent)
    arrays = dict(
        body_shape=shape, body_size=size, body_mass=mass, body_inv_mass=inv_mass, body_inertia=inertia,
        body_inv_inertia=inv_inertia, body_character=character, body_contact_kind=kind, body_fixed=fixed,
        body_rest_pos=rest_pos, body_rest_rot=rest_rot, body_bound_radius=bound, body_seg_a=seg_a,
        body_seg_b=seg_b, body_seg_radius=seg_r, body_joint=body_joint,
        joint_parent=np.array(j_parent, np.int32), joint_child=np.array(j_child, np.int32),
        joint_anchor_parent=np.array(j_ap, np.float64).reshape(nj, 3),
        joint_anchor_child=np.array(j_ac, np.float64).reshape(nj, 3),
        joint_rest_rot=np.array(j_rest, np.float64).reshape(nj, 4),
        joint_locked=np.array(j_locked, np.int32),
        joint_servo_hz=np.array([v[0] for v in j_servo], np.float64),
        joint_servo_zeta=np.array([v[1] for v in j_servo], np.float64),
        feat_body=np.array(f_body, np.int32), feat_local=np.array(f_local, np.float64).reshape(-1, 3),
        feat_radius=np.array(f_rad, np.float64), feat_spin_radius=np.array(f_spin, np.float64),
        pair_a=np.array(pairs_a, np.int32), pair_b=np.array(pairs_b, np.int32),
    )
    # the body-joint tree of the direct joint solve: node b is body b, node n + j joint j;
    # root first, each joint just before its child body; fixed bodies are not nodes
    node_order, node_parent = [], np.full(n + nj, -1, np.int32)
    for b in range(n):
        j = int(body_joint[b])
        if j >= 0:
            a = j_parent[j]
            if not fixed[a]:
                node_parent[n + j] = a
            if not (fixed[a] and fixed[b]):
                node_order.append(n + j)
            if not fixed[b]:
                node_parent[b] = n + j
        if not fixed[b]:
            node_order.append(b)
    arrays["node_order"] = np.array(node_order, np.int32)
    arrays["node_parent"] = node_parent
    chars = []
    for c in sorted(set(character.tolist())):
        idx = np.flatnonzero(character == c)
        if not np.all(np.diff(idx) == 1):
            raise PhysicsError(f"bodies of character {c} must be contiguous", field="character")
        chars.append((int(idx[0]), int(idx[-1]) + 1))
    return PhysicsModel(body_names=names, joint_names=j_names, arrays=arrays, terrain=terrain,
                        settings=settings, characters=chars)


@dataclass
class CreatureBodyOptions:
    """How a creature becomes rigid bodies. ``shape`` 'auto' makes a body a capsule
    along its longest axis when that axis is at least ``capsule_ratio`` times the next
    one, else a box. ``mass`` overrides per body name (kg); ``locked`` names bodies whose
    joint to the parent is locked; ``fixed`` names bodies pinned in place; ``servo_hz`` and
    ``servo_zeta`` set every joint's PD servo (Zordan et al. 2005: one hand-picked gain
    pair for the whole character; mass-normalized here, so one pair suits a mouse and a
    giant)."""

    density: float = 1000.0
    shape: str = "auto"
    capsule_ratio: float = 1.5
    mass: dict = field(default_factory=dict)
    locked: tuple = ()
    fixed: tuple = ()
    servo_hz: float = 0.0
    servo_zeta: float = 1.0


def _creature_specs(creature, character: int, opts: CreatureBodyOptions, prefix: str) -> list[BodySpec]:
    from engine.model.caps import CAP_BIT

    foot_bit = np.uint32(CAP_BIT["foot"])
    for field_name, names in (("locked", opts.locked), ("fixed", opts.fixed), ("mass", opts.mass)):
        for nm in names:
            if not creature.has_body(nm):
                raise PhysicsError(f"creature '{creature.name}' has no body '{nm}'", subject=nm, field=field_name,
                                   path=creature.path)
    if opts.shape not in ("auto", "capsule", "box"):
        raise PhysicsError(f"shape must be auto, capsule or box, got '{opts.shape}'", field="shape")
    specs = []
    for i, name in enumerate(creature.body_names):
        ext = np.array(creature.body_extent[i], dtype=np.float64)
        order = np.argsort(ext)[::-1]
        long_ax = int(order[0])
        use_capsule = opts.shape == "capsule" or (
            opts.shape == "auto" and ext[long_ax] >= opts.capsule_ratio * ext[order[1]])
        parent = int(creature.body_parent[i])
        common = dict(name=prefix + name, pos=np.array(creature.body_rest_pos[i]),
                      rot=np.array(creature.body_rest_rot[i]), density=opts.density,
                      mass=opts.mass.get(name), parent=(parent + 0) if parent >= 0 else -1,
                      joint=np.array(creature.body_joint[i]) if parent >= 0 else None,
                      locked=name in opts.locked, fixed=name in opts.fixed,
                      contact="foot" if (creature.body_caps[i] & foot_bit) else "ground", character=character,
                      servo_hz=opts.servo_hz, servo_zeta=opts.servo_zeta)
        if use_capsule:
            r = float(0.5 * (ext[order[1]] + ext[order[2]]))
            specs.append(BodySpec(shape="capsule", radius=r, half_length=max(float(ext[long_ax]) - r, 0.0),
                                  axis=long_ax, **common))
        else:
            specs.append(BodySpec(shape="box", half_extents=ext, **common))
    return specs


def model_from_creatures(creatures, *, options=None, terrain: Terrain | None = None,
                         settings: WorldSettings | None = None, offsets=None) -> PhysicsModel:
    """Rigid bodies for one or more creatures (each its own character, colliding with
    the others). ``options`` is one ``CreatureBodyOptions`` or one per creature;
    ``offsets`` (one (3,) per creature) moves each creature's rest pose in the world.
    Body names are prefixed ``"<k>:"`` when there is more than one creature."""
    if not isinstance(creatures, (list, tuple)):
        creatures = [creatures]
    if options is None or isinstance(options, CreatureBodyOptions):
        options = [options or CreatureBodyOptions()] * len(creatures)
    if len(options) != len(creatures):
        raise PhysicsError("give one CreatureBodyOptions per creature", field="options")
    specs: list[BodySpec] = []
    for k, (c, opts) in enumerate(zip(creatures, options, strict=True)):
        prefix = f"{k}:" if len(creatures) > 1 else ""
        sub = _creature_specs(c, k, opts, prefix)
        base = len(specs)
        off = np.zeros(3) if offsets is None else _check_vec(offsets[k], 3, "offset", c.name)
        for sp in sub:
            if sp.parent >= 0:
                sp.parent += base
            sp.pos = sp.pos + off
            if sp.joint is not None:
                sp.joint = sp.joint + off
        specs.extend(sub)
    return build_model(specs, terrain=terrain, settings=settings)
