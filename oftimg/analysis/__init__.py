"""The stages of one dataset: the work on each frame (grids, sections, volumes), the
pipeline that wires them (alignment, clipping, tracking, fields, map analyses), the
area maps' analyses, material tracking, and the statistics of cohorts and their maps.
Pure functions on arrays and one :class:`~oftimg.io.dataset.Dataset` read at the
edge; nothing is written here.

Layer 4 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.image`` and the layers
below it.
"""
