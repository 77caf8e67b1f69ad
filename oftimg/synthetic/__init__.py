"""Data with a known truth: the analytic phantom embryo, and any static tube animated
with a known wave, twist and shortening.

Layer 6 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.output`` and the
layers below it.
"""
