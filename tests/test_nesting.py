"""Wall roles from their nesting (issue 71, point 1): a label or probability volume whose
values do not nest as meta.json's labels say (or as the default 1, 2, 3 assumes) is
refused before any work, in one line that names the values found, the nesting seen and
the mapping to write."""

import itertools
import json
import shutil

import numpy as np
import pytest
import tifffile

from oftimg.cli import main
from oftimg.io.label_dataset import load_label_dataset
from oftimg.mesh.nesting import enclosed, label_contacts, layers_present, nesting_order
from oftimg.synthetic.labels import segmentation_noise, write_label_phantom
from oftimg.synthetic.phantom import sample_params

COARSE_UM = (8.0, 8.0, 16.0)


def rings(shape=(40, 48, 48), radii=(20, 14, 9), values=(1, 2, 3)):
    """Coaxial cylinders along z (the volume's first axis), the outermost first: a
    tube's layers, cut by the volume's ends."""
    z, y, x = np.indices(shape)
    r = np.hypot(y - shape[1] / 2 + 0.5, x - shape[2] / 2 + 0.5)
    labels = np.zeros(shape, np.uint8)
    for radius, value in zip(radii, values):
        labels[r < radius] = value
    return labels


def test_contacts_count_each_face_between_two_values_once():
    labels = np.zeros((3, 4, 5), np.uint8)
    labels[:, :, 2:] = 7  # a plane x = 1.5 between 0 and 7
    c = label_contacts(labels)
    assert c.values.tolist() == [0, 7] and c.voxels.tolist() == [24, 36]
    assert c.between(0, 7) == c.between(7, 0) == 3 * 4 and c.between(7, 7) == 0
    wide = label_contacts(labels.astype(np.int32) * 1000)  # np.unique's path
    assert wide.between(0, 7000) == 12 and wide.count(7000) == 36
    both = c + label_contacts(np.full((2, 2, 2), 9, np.uint8))
    assert both.values.tolist() == [0, 7, 9] and both.count(9) == 8 and both.between(0, 7) == 12


@pytest.mark.parametrize("values", list(itertools.permutations((1, 2, 3))))
def test_the_nesting_is_read_off_the_geometry_whatever_the_numbers(values):
    c = label_contacts(rings(values=values))
    assert nesting_order(c, [1, 2, 3]) == list(values)
    assert enclosed(c, values[0], values[1]) and enclosed(c, values[1], values[2])


def test_noise_and_specks_do_not_change_the_nesting():
    rng = np.random.default_rng(4)
    labels = segmentation_noise(rings(values=(5, 9, 2)), 0.08, rng)
    labels[rng.random(labels.shape) < 1e-4] = 40  # a speck value, a few voxels
    c = label_contacts(labels)
    assert layers_present(c) == [2, 5, 9]
    assert nesting_order(c, layers_present(c)) == [5, 9, 2]


def test_a_myocardium_eroded_to_shreds_is_still_the_outermost():
    """The zoo's first draws: a myocardium one voxel thick with holes (a wall eroded by
    a voxel at coarse voxels) leaves the jelly touching the background more than the
    myocardium does; the layers' depths still nest."""
    rng = np.random.default_rng(2)
    labels = rings(radii=(15, 14, 8), values=(6, 4, 41))
    shell = labels == 6
    labels[shell & (rng.random(labels.shape) < 0.85)] = 0  # 85 % of it gone
    c = label_contacts(labels)
    assert c.between(0, 4) > c.between(0, 6)  # by contact: the jelly out
    assert nesting_order(c, [4, 6, 41]) == [6, 4, 41]


def test_layers_side_by_side_are_not_enclosed():
    labels = np.zeros((20, 30, 60), np.uint8)
    labels[:, 5:25, 5:28] = 1
    labels[:, 5:25, 32:55] = 2
    c = label_contacts(labels)
    assert not enclosed(c, 1, 2) and not enclosed(c, 2, 1)


@pytest.fixture(scope="module")
def labelled(tmp_path_factory):
    """A small label phantom: 6 frames, myocardium 1, jelly 2, lumen 3, with noise."""
    path = tmp_path_factory.mktemp("nesting") / "lp"
    return write_label_phantom(path, sample_params("normal", 1, n_frames=6), COARSE_UM, noise=0.05)


def relabelled(src, dst, table: dict, labels=None):
    """A copy of label dataset ``src`` with every value v written as table[v] and
    meta.json's labels replaced by ``labels`` (None: removed)."""
    shutil.copytree(src, dst)
    lut = np.arange(256, dtype=np.uint8)
    for old, new in table.items():
        lut[old] = new
    for f in sorted((dst / "labels").iterdir()):
        tifffile.imwrite(f, lut[tifffile.imread(f)], compression="zlib")
    meta = json.loads((dst / "meta.json").read_text())
    meta.pop("labels")
    if labels is not None:
        meta["labels"] = labels
    (dst / "meta.json").write_text(json.dumps(meta))
    return dst


def refusal(capsys, folder) -> str:
    assert main(["validate", str(folder)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"oftimg: error: {folder / 'labels'}: "), err
    return err[0]


@pytest.mark.parametrize("order", [p for p in itertools.permutations((1, 2, 3)) if p != (1, 2, 3)])
def test_a_wrong_numbering_is_refused_with_the_mapping_to_write(labelled, tmp_path, capsys, order):
    """Lumen 1, jelly 2, myocardium 3 with no labels in meta.json ran to exit 0 with all
    three walls on one surface."""
    bad = relabelled(labelled, tmp_path / "bad", dict(zip((1, 2, 3), order)))
    line = refusal(capsys, bad)
    assert "do not nest as myocardium 1 around jelly 2 around lumen 3" in line
    assert "so myocardium 1, jelly 2, lumen 3 were assumed" in line
    assert f"{order[0]} encloses {order[1]}, which encloses {order[2]}" in line
    mapping = json.dumps({"myocardium": order[0], "jelly": order[1], "lumen": order[2]})
    assert f'write "labels": {mapping} in {bad / "meta.json"}' in line
    good = relabelled(
        labelled, tmp_path / "good", dict(zip((1, 2, 3), order)), labels=json.loads(mapping)
    )  # as the line says: accepted
    assert load_label_dataset(good).label_ids == json.loads(mapping)


def test_other_values_without_a_mapping_are_named_with_their_counts(labelled, tmp_path, capsys):
    """Labels 10 / 20 / 30 said every frame "holds no labelled voxel (all zero)", 48 times."""
    line = refusal(capsys, relabelled(labelled, tmp_path / "tens", {1: 10, 2: 20, 3: 30}))
    assert "no voxel holds myocardium 1, jelly 2, lumen 3" in line
    assert "values found are 10 (" in line and " voxels), 20 (" in line
    assert '"labels": {"myocardium": 10, "jelly": 20, "lumen": 30}' in line


def test_a_mapping_that_names_an_absent_or_wrong_value_is_refused(labelled, tmp_path, capsys):
    absent = relabelled(
        labelled, tmp_path / "absent", {}, labels={"myocardium": 1, "jelly": 2, "lumen": 7}
    )
    line = refusal(capsys, absent)
    assert 'no voxel holds lumen 7 (meta.json\'s "labels")' in line
    swapped = relabelled(
        labelled, tmp_path / "swapped", {}, labels={"myocardium": 3, "jelly": 2, "lumen": 1}
    )
    line = refusal(capsys, swapped)
    assert "do not nest as myocardium 3 around jelly 2 around lumen 1" in line
    assert '"labels": {"myocardium": 1, "jelly": 2, "lumen": 3}' in line


def test_merged_layers_are_refused_and_a_lone_myocardium_is_the_outer_wall(
    labelled, tmp_path, capsys
):
    merged = relabelled(labelled, tmp_path / "merged", {3: 2})  # jelly and lumen as one
    line = refusal(capsys, merged)
    assert "no voxel holds lumen 3" in line
    assert '"labels": {"myocardium": 1, "lumen": 2}' in line
    alone = relabelled(labelled, tmp_path / "alone", {2: 1, 3: 1})
    assert load_label_dataset(alone).label_ids == {"myocardium": 1}


def test_swapped_probability_folders_are_refused(tmp_path, capsys):
    path = write_label_phantom(
        tmp_path / "pm",
        sample_params("normal", 0, n_frames=5),
        (12.0, 12.0, 24.0),
        probabilities=True,
    )
    assert load_label_dataset(path).label_ids == {"myocardium": 1, "jelly": 2, "lumen": 3}
    folder = path / "probabilities"
    (folder / "lumen").rename(folder / "swap")
    (folder / "myocardium").rename(folder / "lumen")
    (folder / "swap").rename(folder / "myocardium")
    assert main(["validate", str(path)]) == 2
    line = capsys.readouterr().err.strip()
    assert line.startswith(
        f"oftimg: error: {folder}: the layers do not nest as its folders "
        "say myocardium/ around jelly/ around lumen/"
    )
    assert "3 encloses 2, which encloses 1" in line and "\n" not in line
