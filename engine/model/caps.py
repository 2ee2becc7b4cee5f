"""Capabilities ("caps"): the tags that tell the animation system what a body is.

Hecker et al. 2008, section 1.2. A body's caps are stored as bits of a ``uint32`` so
kernels can test them with one AND; people and files use the names.
"""

from __future__ import annotations

import numpy as np

#: Capability names in bit order. Append only: files and caches store bits.
CAPABILITIES: tuple[str, ...] = (
    "spine",
    "limb",
    "grasper",
    "foot",
    "mouth",
    "eye",
    "head",
    "tail",
    "wing",
    "ear",
    "spike",
    "detail",
)

CAP_BIT: dict[str, int] = {name: 1 << i for i, name in enumerate(CAPABILITIES)}

SPINE = CAP_BIT["spine"]
LIMB = CAP_BIT["limb"]
GRASPER = CAP_BIT["grasper"]
FOOT = CAP_BIT["foot"]
MOUTH = CAP_BIT["mouth"]
EYE = CAP_BIT["eye"]
HEAD = CAP_BIT["head"]
TAIL = CAP_BIT["tail"]
WING = CAP_BIT["wing"]
EAR = CAP_BIT["ear"]
SPIKE = CAP_BIT["spike"]
DETAIL = CAP_BIT["detail"]


def caps_to_bits(names: list[str] | tuple[str, ...]) -> int:
    """Bits of a list of capability names; raises ``KeyError`` naming the unknown one."""
    bits = 0
    for name in names:
        bits |= CAP_BIT[name]
    return bits


def bits_to_caps(bits: int | np.integer) -> list[str]:
    """Capability names of a bit set, in canonical order."""
    b = int(bits)
    return [name for name in CAPABILITIES if b & CAP_BIT[name]]
