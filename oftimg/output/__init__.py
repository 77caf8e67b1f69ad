"""Results written and read back: arrays and summaries (``export``, ``results``),
figures, videos, the cohort table and report pages, ParaView and TIFF exports.

Layer 5 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.analysis`` and the
layers below it.
"""
