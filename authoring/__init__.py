"""Menagerie's tools on top of the engine: the viewer and the authoring tool.

``authoring.scene`` and ``authoring.geometry`` describe what to draw as plain numpy data
and work without a window; ``authoring.render`` draws it with pyglet/OpenGL (headless
EGL when there is no display); ``authoring.viewer`` is the window and the entry points
``view``, ``view_file`` and ``snapshot_creatures``. The authoring tool (``menagerie
author``) is an editing model that works without a window (``authoring.document``,
``authoring.preview``, ``authoring.editor``, ``authoring.gait_edit``) under a thin Dear
ImGui layer (``authoring.author``, the optional ``author`` extra). ``authoring`` depends
on ``engine``, never the reverse; importing this package does not import pyglet.
"""
