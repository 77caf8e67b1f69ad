"""The dataset contract at the edge: mesh files read and written, a dataset's folders,
meta.json and frames found, every frame validated before any work.

Layer 2 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.errors``,
``oftimg.progress`` and ``oftimg.mesh`` only.
"""
