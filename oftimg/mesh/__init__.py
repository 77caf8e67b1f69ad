"""Per-frame geometry of one triangle mesh: topology and repair, geodesics, the
(u, v) map and grid, section planes and contours, curvatures, in-surface strain,
clipping. Functions of ``V (n_vert, 3)``, ``F (n_face, 3)`` and grids.

Layer 1 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.errors`` only.
"""
