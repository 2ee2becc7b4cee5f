"""Menagerie's tools on top of the engine: the viewer (and, later, the authoring tool).

``authoring.scene`` and ``authoring.geometry`` describe what to draw as plain numpy data
and work without a window; ``authoring.render`` draws it with pyglet/OpenGL (headless
EGL when there is no display); ``authoring.viewer`` is the window and the entry points
``view``, ``view_file`` and ``snapshot_creatures``. ``authoring`` depends on ``engine``,
never the reverse; importing this package does not import pyglet.
"""
