"""Context queries (Hecker et al. 2008, section 3.1): which bodies a channel poses.

Game code uses them too::

    from engine.query import Query, select, nearest
    Query(type="grasper", x="front", extent="leftmost").evaluate(creature)
    select(creature, "foot", left=True)           # all feet on the left
    nearest(creature, "grasper", fruit_position)  # the grasper nearest the fruit
"""

from engine.query.query import (
                                AXIS_ZONES,
                                CENTER_ZONE,
                                EXTENTS,
                                LIMB_MODIFIERS,
                                QUERY_TYPES,
                                SPACES,
                                Query,
                                nearest,
                                select,
)

__all__ = ["AXIS_ZONES", "CENTER_ZONE", "EXTENTS", "LIMB_MODIFIERS", "QUERY_TYPES", "SPACES", "Query",
           "nearest", "select"]
