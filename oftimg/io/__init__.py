"""The dataset contract at the edge, one module per concern: mesh files read and
written (:mod:`~oftimg.io.meshfile`), one frame of one wall read and checked as an
open tube (:mod:`~oftimg.io.tube`), and a dataset's folders, meta.json and frames
found and every frame validated before any work (:mod:`~oftimg.io.dataset`).

Layer 2 of oftimg (see :data:`oftimg.LAYERS`): imports ``oftimg.errors``,
``oftimg.progress`` and ``oftimg.mesh`` only.
"""
