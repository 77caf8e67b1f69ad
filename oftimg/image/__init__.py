"""Maps and fields as images: (v, t) kymographs (ridge, wave speeds), masks,
derivative images, band detection, per-pixel normalisation and phase maps, the
cycle's timing and time warps, cross-section shape PCA.

Layer 3 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.io``, ``oftimg.mesh``
and the leaves (``errors``, ``progress``).
"""
