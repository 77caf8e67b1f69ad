"""oftimg in napari: a results folder opened as the walls' surfaces over time, on
napari's own time slider, coloured by any (u, v, t) field (``pip install
"oftimg[napari]"``; the plugin is found through the ``napari.manifest`` entry point).
oftimg itself never imports napari: only this package's functions need it.
"""
