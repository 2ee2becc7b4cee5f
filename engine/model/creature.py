"""The Creature: a creature's morphology, immutable after build.

Struct-of-arrays, bodies ordered parents first (``body_parent[i] < i``) with the root at
index 0, in depth-first order so every sub-tree is a contiguous range. Everything the
runtime needs from the shape is derived once by ``engine.model.builder`` (Hecker et al.
2008, sections 1.2, 3.1 and 4.3.1): the spine chain, limbs and where they attach, limb
lengths, legs, bounds for context queries, body sides and mirror partners, and the
root-relative rest pose.

Array fields (all read-only; n = nbody):

Bodies
    body_parent (n,) int32            parent index, -1 for the root
    body_caps (n,) uint32             capability bits (``engine.model.caps``)
    body_rest_pos (n, 3) float64      rest position of the body origin (box centre), m
    body_rest_rot (n, 4) float64      rest rotation, w-first unit quaternion
    body_joint (n, 3) float64         rest position of the joint to the parent (root: its pos)
    body_extent (n, 3) float64        box half-extents in the body frame, m, > 0
    body_local_pos (n, 3) float64     rest position in the parent's frame (root: character space)
    body_local_rot (n, 4) float64     rest rotation relative to the parent (root: character space)
    body_local_joint (n, 3) float64   joint point in the parent's frame (root: its pos)
    body_joint_offset (n, 3) float64  body origin relative to its own joint, in its own frame
    body_rootrel_pos (n, 3) float64   rest position in the root's frame (root-relative rest pose)
    body_rootrel_rot (n, 4) float64   rest rotation relative to the root
    body_rootrel_joint (n, 3) float64 joint point in the root's frame
    body_depth (n,) int32             edges from the root
    body_subtree_end (n,) int32       the sub-tree of i is the index range [i, end)
    body_child_adr (n,) int32, body_child_num (n,) int32, child_list (n-1,) int32
                                      children of i: child_list[adr : adr + num]
    body_side (n,) int8               +1 left (y > 0), -1 right, 0 on the sagittal plane
    body_mirror (n,) int32            sagittal mirror partner, itself on the plane, -1 if none
    body_is_spine (n,) bool
    body_spine_attach (n,) int32      the spine body a body hangs off (itself for spine bodies)
    body_limb (n,) int32              limb index, -1 for spine bodies
    body_limb_length (n,) float64     path length along joints from the spine attachment
                                      to the body's joint (0 on the spine), m

Spine and limbs
    spine_chain (nspine,) int32       spine bodies end to end, from the back/bottom end to
                                      the front/top end (see ``_order_spine``)
    spine_root_index int              position of the root in ``spine_chain``
    limb_root (nlimb,) int32          first body of each limb (a non-spine child of the spine)
    limb_attach (nlimb,) int32        spine body the limb hangs off

Legs (a leg runs from a foot body up to the spine hip it hangs off)
    leg_foot (nleg,) int32, leg_hip (nleg,) int32, leg_length (nleg,) float64
    leg_body_adr (nleg,) int32, leg_body_num (nleg,) int32, leg_bodies (...) int32
                                      bodies of leg k from the foot up to the limb root

Bounds (rest pose, from the corners of every body box)
    bounds (2, 3) float64             character bounding box [min, max]
    cap_bounds (ncap, 2, 3) float64   bounding box of the bodies with each capability
    cap_count (ncap,) int32           how many bodies have each capability
"""

from __future__ import annotations

import difflib
import os
from typing import TYPE_CHECKING

import numpy as np

from engine.model.caps import CAP_BIT, CAPABILITIES, bits_to_caps

if TYPE_CHECKING:
    from engine.model.definition import CreatureDef


class Creature:
    """An immutable creature. Build one with ``engine.load_creature`` or
    ``engine.model.build_creature``; see the module docstring for the arrays."""

    _frozen = False

    def __init__(self, *, name: str, description: str, path: str | None,
                 body_names: tuple[str, ...], arrays: dict[str, np.ndarray],
                 spine_root_index: int, source: dict | None = None) -> None:
        self.name = name
        self.description = description
        self.path = path
        #: The glTF rig it was made from (``CreatureDef.source``), or None.
        self.source = source
        self.body_names = body_names
        self._index = {n: i for i, n in enumerate(body_names)}
        self.spine_root_index = int(spine_root_index)
        for key, value in arrays.items():
            value = np.ascontiguousarray(value)
            value.flags.writeable = False
            setattr(self, key, value)
        self._frozen = True

    def __setattr__(self, key, value):
        if self._frozen:
            raise AttributeError(f"Creature '{self.name}' is immutable (tried to set '{key}')")
        object.__setattr__(self, key, value)

    # -- sizes -------------------------------------------------------------------------

    @property
    def nbody(self) -> int:
        """Number of bodies."""
        return len(self.body_names)

    @property
    def nleg(self) -> int:
        return int(self.leg_foot.shape[0])

    @property
    def nlimb(self) -> int:
        return int(self.limb_root.shape[0])

    @property
    def root(self) -> int:
        """Index of the root body (always 0)."""
        return 0

    @property
    def size(self) -> np.ndarray:
        """Extent of the character's bounding box along x, y, z (m)."""
        return self.bounds[1] - self.bounds[0]

    @property
    def height(self) -> float:
        """Height of the top of the bounding box above the ground plane z = 0 (m)."""
        return float(self.bounds[1, 2])

    # -- names -------------------------------------------------------------------------

    def body(self, name: str) -> int:
        """Index of the body called ``name``; a ``KeyError`` suggests near names."""
        try:
            return self._index[name]
        except KeyError:
            close = difflib.get_close_matches(name, self.body_names, n=3)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise KeyError(f"creature '{self.name}' has no body '{name}'{hint}") from None

    def has_body(self, name: str) -> bool:
        return name in self._index

    def caps_of(self, index: int) -> list[str]:
        """Capability names of body ``index``."""
        return bits_to_caps(self.body_caps[index])

    def has_cap(self, index: int, cap: str) -> bool:
        return bool(int(self.body_caps[index]) & CAP_BIT[cap])

    def bodies_with(self, cap: str) -> np.ndarray:
        """Indices (int32, ascending) of the bodies with capability ``cap``."""
        if cap not in CAP_BIT:
            raise KeyError(f"unknown capability '{cap}' (known: {', '.join(CAPABILITIES)})")
        return np.flatnonzero(self.body_caps & np.uint32(CAP_BIT[cap])).astype(np.int32)

    def children(self, index: int) -> np.ndarray:
        a = int(self.body_child_adr[index])
        return self.child_list[a : a + int(self.body_child_num[index])]

    def leg_path(self, leg: int) -> np.ndarray:
        """Bodies of leg ``leg`` from its foot up to the first body below the hip."""
        a = int(self.leg_body_adr[leg])
        return self.leg_bodies[a : a + int(self.leg_body_num[leg])]

    # -- counts for people -------------------------------------------------------------

    def counts(self) -> dict[str, int]:
        """Body, spine, leg, arm (grasper), head, mouth, eye, wing and tail counts."""
        return {
            "bodies": self.nbody,
            "spine": int(self.spine_chain.shape[0]),
            "legs": self.nleg,
            "arms": int(self.cap_count[CAPABILITIES.index("grasper")]),
            "heads": int(self.cap_count[CAPABILITIES.index("head")]),
            "mouths": int(self.cap_count[CAPABILITIES.index("mouth")]),
            "eyes": int(self.cap_count[CAPABILITIES.index("eye")]),
            "wings": int(self.cap_count[CAPABILITIES.index("wing")]),
            "tails": int(self.cap_count[CAPABILITIES.index("tail")]),
        }

    def __repr__(self) -> str:
        c = self.counts()
        return (f"Creature('{self.name}', bodies={c['bodies']}, spine={c['spine']}, "
                f"legs={c['legs']}, arms={c['arms']}, heads={c['heads']})")

    # -- back to a definition ----------------------------------------------------------

    def to_def(self) -> CreatureDef:
        """A definition that builds this creature again, in this body order."""
        from engine.model.definition import BodyDef, CreatureDef

        bodies = []
        for i, name in enumerate(self.body_names):
            parent = int(self.body_parent[i])
            bodies.append(BodyDef(
                name=name,
                parent=self.body_names[parent] if parent >= 0 else None,
                caps=self.caps_of(i),
                pos=tuple(float(v) for v in self.body_rest_pos[i]),
                rot=tuple(float(v) for v in self.body_rest_rot[i]),
                joint=tuple(float(v) for v in self.body_joint[i]),
                extents=tuple(float(v) for v in self.body_extent[i]),
            ))
        return CreatureDef(name=self.name, description=self.description, bodies=bodies,
                           path=self.path, source=dict(self.source) if self.source else None)

    def save(self, path: str | os.PathLike, *, overwrite: bool = False) -> None:
        """Write the creature file (format 1). Refuses to replace a file unless asked."""
        from engine.model.fileio import write_creature_def

        write_creature_def(self.to_def(), path, overwrite=overwrite)
