"""A results folder (``oftimg run``'s ``OUT/<name>``, or a run's ``OUT``) or a dataset
folder opened in napari (its reader hook): a result's walls over time
(:mod:`oftimg.napari.surfaces`) over the volumes of the dataset it was made from
(:mod:`oftimg.napari.volumes`), its fields and maps as images beside them
(:mod:`oftimg.napari.maps`).
"""

from __future__ import annotations

from pathlib import Path

from ..io.dataset import is_dataset
from ..output.results import load_results, result_folders
from .maps import map_layers
from .surfaces import WALLS, wall_layer
from .volumes import dataset_layers, result_volumes


def results_layers(path, field: str | None = None) -> list[tuple]:
    """Every wall of every dataset's results under ``path`` (one results folder or a
    run's ``--out``) as napari layer-data tuples (:func:`~oftimg.napari.surfaces.wall_layer`), over the
    volumes of the dataset each was made from when it is still there
    (:func:`~oftimg.napari.volumes.result_volumes`), with its fields and maps as
    images beside them, hidden (:func:`~oftimg.napari.maps.map_layers`)."""
    layers = []
    for folder in result_folders(path):
        results = load_results(folder)
        layers += [v.layer_data() for v in result_volumes(results)]
        layers += [wall_layer(results, w, field) for w in WALLS if w in results]
        layers += map_layers(results)
    return layers


def napari_get_reader(path):
    """napari's reader hook: :func:`results_layers` for a results folder or a run's
    ``--out`` (a folder with summary.json, or with run.json),
    :func:`~oftimg.napari.volumes.dataset_layers` for a dataset folder (meshes, labels,
    intensity volumes), else None (another plugin may read it)."""
    if isinstance(path, list):
        path = path[0] if len(path) == 1 else None
    if path is None:
        return None
    path = Path(path)
    if not path.is_dir():
        return None
    if (path / "summary.json").is_file() or (path / "run.json").is_file():
        return results_layers
    if is_dataset(path):
        return dataset_layers
    return None
