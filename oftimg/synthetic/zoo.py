"""A randomized phantom zoo: datasets drawn from wide distributions, each with its
truth, so that accuracy is measured as a distribution over the data labs bring rather
than on the one phantom a method was tuned beside.

:func:`draw_scenario` draws a :class:`Scenario` from a seed (deterministic: the same
seed, the same scenario): the input kind (meshes, label volumes, probability maps,
labels with intensity volumes), frames per cycle, period, the wave's speeds and
shape (with or without a band), the expansion's share and its change along the tube,
the tissue's slide and twist (largest at the inlet, the outlet or mid-tube, at any
phase against the slide), a real tube's shape animated with a known wave, twist and
shortening (its tissue traced in every frame), the texture and how it is imaged (grain, contrast, its
change through the wall, speckle, attenuation), the voxel size and anisotropy, a
segmentation's defects (boundary flips, islands, a wall eroded or dilated by a voxel,
holes and handles in a few frames), the label values and the file format, the tube
cut by the volume's faces at both ends (square, or obliquely at 20-50 degrees) or going
on past one end and ending inside the volume (meta.json's "ends" then cut it), and for
meshes their roughness and vertex counts. :func:`write_scenario` writes it as a
dataset folder with ``truth.json`` (the model's answers) and ``scenario.json`` (what
was drawn).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from .label_defects import DEFECTS, inject
from .labels import write_label_phantom
from .phantom import PhantomParams, sample_params, write_phantom
from .texture import TextureParams

KINDS = ("meshes", "labels", "probabilities", "labels+intensity", "real")
FORMATS = ("tif", "tif4d", "npy", "nii", "zarr")
LAYERS = ("myocardium", "jelly", "lumen")
# what a draw ranges over (uniform between the two numbers unless said)
RANGES = {
    "n_frames": (30, 200),
    "period_ms": (250.0, 600.0),
    "speed_proximal_mm_s": (3.0, 15.0),
    "distal_over_proximal": (1.0, 4.0),
    "knee_share": (0.25, 0.75),
    "knee_width_mm": (0.03, 0.2),
    "expand_fraction": (0.3, 0.55),
    "expand_change": (-0.15, 0.15),
    "contraction": (0.15, 0.4),
    "twist_deg": (0.0, 30.0),
    "slide": (0.0, 0.15),
    "band_share": (0.3, 0.7),
    "band_depth": (0.2, 0.5),
    "noise_mm": (0.0, 0.005),
    "vertices_min": (1500, 8000),
    "voxel_um": (2.0, 8.0),
    "anisotropy": (1.0, 3.0),
    "flip": (0.0, 0.08),
    "islands": (0, 60),
    "probability_noise": (0.1, 0.6),
    "blob_um": (3.0, 12.0),
    "contrast": (0.15, 0.5),
    "depth_sigma": (0.3, 4.0),
    "speckle": (0.15, 0.5),
    "attenuation_mm": (0.5, 3.0),
    # a real shape animated (oftimg.synthetic.animate): its wave, twist and shortening
    "real_speed_lengths_s": (2.0, 15.0),
    "real_amplitude": (0.1, 0.4),
    "real_shortening": (0.0, 0.15),
    # with fronts=True: a one-sided front's lag to the far side, a share of the period
    "side_lag_share": (0.05, 0.25),
    # label draws cut obliquely by the volume's faces: the angle from square, degrees
    "oblique_deg": (20.0, 50.0),
    # with features=True: sharper corners or concave notches (phantom corner_profile's
    # kappa), 3 to 6 of them, and meshes from coarse to fine (vertices round the outer wall)
    "corners": (3, 6),
    "corner_sharpness": (-1.5, 1.5),
    "vertices_around": (40, 200),
    # with cushions=True: the lumen an ellipse whose minor over major axis falls from the
    # expanded aspect to the contracted one (at or below 0: closed) over a stretch of the
    # tube (a share of its length), its major axis at any angle; mesh draws' lumens meshed
    # from voxels of this side (mm), as a lab meshes its segmentation (in pieces where closed)
    "cushion_aspect_expanded": (0.5, 0.95),
    "cushion_aspect_contracted": (-0.6, 0.2),
    "cushion_stretch": (0.2, 0.5),
    "cushion_taper_mm": (0.05, 0.15),
    "cushion_lumen_voxel_mm": (0.004, 0.008),
    # with speckled=True (labels + intensity): the instrument's look and the tissue's
    # motion widened: fully developed speckle carried by the tissue and renewed as it
    # moves (over a step of this many voxels), texture grain from under a voxel to coarse
    # (Gaussian sigma in voxels), slide and twist larger
    "speckled_speckle": (0.15, 1.0),
    "speckled_decorrelation_voxels": (0.5, 4.0),
    "speckled_grain_voxels": (0.4, 3.0),
    "speckled_contrast": (0.15, 0.5),
    "speckled_slide": (0.0, 0.2),
    "speckled_twist_deg": (0.0, 40.0),
}
BANDED_SHARE = 0.3  # of the draws: a band
SYSTEMATIC_SHARE = 0.3  # of the label draws: a wall eroded or dilated by one voxel
DEFECT_SHARE = 0.3  # of the label draws: a defect in one or two frames
OWN_VALUES_SHARE = 0.5  # of the label draws: values other than 1, 2, 3
END_INSIDE_SHARE = 0.3  # of the label draws: the tube ends inside the volume at one end
END_INSIDE_VOXELS = (4, 16)  # how far it goes on past the window's plane there
OBLIQUE_SHARE = 0.5  # of the other label draws: the faces cut the tube obliquely
# with fronts=True (the wave-front draws): a helical front in this share of the draws
# (1 or 2 starts, either hand); a one-sided front in the others, and in this share of
# the helical ones too
HELIX_SHARE = 0.5
HELIX_AND_SIDE_SHARE = 0.3


@dataclass(frozen=True)
class Segmentation:
    """What a label draw's segmentation does beyond the phantom's truth: ``flip`` (the
    share of boundary voxels given a neighbour's label) and ``islands`` (specks per
    frame); ``systematic``: ``(layer, voxels)``, that layer's region grown (+1) or
    shrunk (-1) by a voxel in every frame, or None; ``defects``: frame -> a defect of
    :data:`~oftimg.synthetic.label_defects.DEFECTS`; ``values``: layer -> the value
    written for it (meta.json's ``labels``); ``file_format``: one of :data:`FORMATS`;
    ``probability_noise``: for probability maps, the noise's SD on the log-probabilities."""

    flip: float = 0.05
    islands: int = 30
    systematic: tuple | None = None
    defects: dict = field(default_factory=dict)
    values: dict = field(default_factory=lambda: {"myocardium": 1, "jelly": 2, "lumen": 3})
    file_format: str = "tif"
    probability_noise: float = 0.3


@dataclass(frozen=True)
class Scenario:
    """One draw of the zoo: the input ``kind`` (:data:`KINDS`), the phantom's
    parameters, and for label kinds the voxel size (um, x y z), the segmentation and
    (with intensity) the texture."""

    seed: int
    kind: str
    phantom: PhantomParams
    voxel_um: tuple | None = None
    segmentation: Segmentation | None = None
    texture: TextureParams | None = None
    animation: dict | None = None  # kind "real": the wave in tube lengths a second,
    #                                   amplitude, twist, shortening, frames, period
    # label kinds: the end ("inlet" or "outlet") where the tube goes on past the window's
    # plane and ends inside the volume (meta.json "ends" then cuts it), and by how many
    # voxels it goes on; None: the volume's faces cut both ends
    end_inside: str | None = None
    end_inside_voxels: int = 0
    # label kinds whose tube leaves the volume at both ends: the faces' angle to it
    # there, from square (degrees; 0: the faces cut it square)
    oblique_deg: float = 0.0

    def as_dict(self) -> dict:
        out = asdict(self)
        if self.segmentation is not None:  # JSON keys are text: frames as strings
            out["segmentation"]["defects"] = {
                str(k): v for k, v in self.segmentation.defects.items()
            }
        return out


def _uniform(rng, name: str) -> float:
    low, high = RANGES[name]
    return float(rng.uniform(low, high))


def draw_scenario(
    seed: int,
    kind: str | None = None,
    *,
    n_frames: int | None = None,
    voxel_um_min: float | None = None,
    fronts: bool = False,
    oblique: bool | None = None,
    features: bool = False,
    cushions: bool = False,
    speckled: bool = False,
) -> Scenario:
    """The scenario of ``seed`` (the same seed, the same draw): ``kind`` drawn from
    :data:`KINDS` unless given, every number from :data:`RANGES`. ``n_frames`` and
    ``voxel_um_min`` (the finest voxel side drawn) override the draw, for quick runs:
    the rest of the draw is the same. ``fronts``: the wave's fronts are not the
    cross-sections but a helix (:data:`HELIX_SHARE`) or come first on one side, or
    both (:func:`front_params`); the rest of the draw is the same. ``oblique``: a label
    draw's volume cuts the tube at both ends obliquely (True: at its drawn angle,
    :data:`RANGES` ``oblique_deg``) or square (False), none ending inside, the rest of
    the draw the same (a pair for a paired comparison); None: as drawn. ``features``:
    the section's corners drawn sharper or as concave notches and 3-6 of them, and the
    meshes 40-200 vertices round the tube (:func:`feature_params`); the rest the same.
    ``cushions``: the lumen elliptical, falling towards a slit and in label kinds often
    closing over a stretch of the tube for part of the beat (:func:`cushion_params`).
    ``speckled``: labels with intensity as the instrument images them, the tissue's
    slide and twist larger (:func:`speckled_params`); the rest the same."""
    rng = np.random.default_rng([seed, 72])
    drawn_kind = KINDS[int(rng.integers(len(KINDS)))]
    kind = drawn_kind if kind is None else kind
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, found {kind!r}")
    group = "banded" if rng.random() < BANDED_SHARE else "normal"
    base = sample_params(group, seed)
    length = base.length_mm
    frames = int(rng.integers(RANGES["n_frames"][0], RANGES["n_frames"][1] + 1))
    proximal = _uniform(rng, "speed_proximal_mm_s")
    expand = _uniform(rng, "expand_fraction")
    change = _uniform(rng, "expand_change") if rng.random() < 0.5 else 0.0
    v_min = int(rng.integers(*RANGES["vertices_min"]))
    params = replace(
        base,
        n_frames=frames if n_frames is None else n_frames,
        period_ms=_uniform(rng, "period_ms"),
        speed_proximal_mm_s=proximal,
        speed_distal_mm_s=proximal * _uniform(rng, "distal_over_proximal"),
        speed_knee_mm=_uniform(rng, "knee_share") * length,
        speed_knee_width_mm=_uniform(rng, "knee_width_mm"),
        expand_fraction=expand,
        expand_fraction_outlet=float(np.clip(expand + change, 0.2, 0.7)) if change else None,
        contraction=_uniform(rng, "contraction"),
        twist_deg=_uniform(rng, "twist_deg"),
        twist_profile=str(rng.choice(["inlet", "outlet", "middle"])),
        twist_phase=float(rng.uniform(0, 1)),
        stretch=_uniform(rng, "slide"),
        band_position_mm=(_uniform(rng, "band_share") * length if group == "banded" else None),
        band_depth=_uniform(rng, "band_depth"),
        noise_mm=_uniform(rng, "noise_mm") if kind == "meshes" else 0.0,
        vertices_min=v_min,
        vertices_max=int(1.5 * v_min),
    )
    if fronts:
        params = replace(params, **front_params(seed, params.period_ms))
    if features:
        params = replace(params, **feature_params(seed, params))
    if cushions:
        params = replace(params, **cushion_params(seed, params, kind))
    side = _uniform(rng, "voxel_um")
    if voxel_um_min is not None:
        side = max(side, voxel_um_min)
    voxel = (side, side, side * _uniform(rng, "anisotropy"))
    systematic = (
        (str(rng.choice(LAYERS)), int(rng.choice([-1, 1])))
        if rng.random() < SYSTEMATIC_SHARE
        else None
    )
    n_defects = int(rng.integers(1, 3)) if rng.random() < DEFECT_SHARE else 0
    at = rng.uniform(0, 1, n_defects)  # where in the cycle: any frame count
    defects = {int(share * params.n_frames): str(rng.choice(sorted(DEFECTS))) for share in at}
    values = (
        {layer: int(v) for layer, v in zip(LAYERS, rng.choice(np.arange(1, 251), 3, replace=False))}
        if rng.random() < OWN_VALUES_SHARE
        else dict(zip(LAYERS, (1, 2, 3)))
    )
    segmentation = Segmentation(
        flip=_uniform(rng, "flip"),
        islands=int(rng.integers(*RANGES["islands"])),
        systematic=systematic,
        defects=defects,
        values=values,
        file_format=str(rng.choice(FORMATS)),
        probability_noise=_uniform(rng, "probability_noise"),
    )
    texture = TextureParams(
        blob_um=_uniform(rng, "blob_um"),
        contrast=_uniform(rng, "contrast"),
        depth_sigma=_uniform(rng, "depth_sigma"),
        speckle=_uniform(rng, "speckle"),
        attenuation_mm=_uniform(rng, "attenuation_mm"),
    )
    animation = {
        "speed_lengths_s": _uniform(rng, "real_speed_lengths_s"),
        "amplitude": _uniform(rng, "real_amplitude"),
        "twist_deg": float(params.twist_deg * (-1) ** int(rng.integers(2))),
        "shortening": _uniform(rng, "real_shortening"),
        "n_frames": params.n_frames,
        "period_ms": params.period_ms,
    }
    # drawn from a stream of their own, so that the draws above stay as they were
    more = np.random.default_rng([seed, 72, 1])
    end_inside = str(more.choice(["inlet", "outlet"])) if more.random() < END_INSIDE_SHARE else None
    end_voxels = int(more.integers(*END_INSIDE_VOXELS)) if end_inside else 0
    cut = np.random.default_rng([seed, 72, 3])
    drawn_oblique = cut.random() < OBLIQUE_SHARE
    angle = _uniform(cut, "oblique_deg")
    if oblique is not None:
        end_inside, end_voxels, drawn_oblique = None, 0, oblique
    oblique = angle if drawn_oblique and not end_inside else 0.0
    if speckled:
        motion, texture = speckled_params(seed, side)
        params = replace(params, **motion)
        animation["twist_deg"] = float(params.twist_deg * np.sign(animation["twist_deg"]))
    if kind == "meshes":
        return Scenario(seed, kind, params)
    if kind == "real":
        return Scenario(seed, kind, params, animation=animation)
    return Scenario(
        seed,
        kind,
        params,
        voxel,
        segmentation,
        texture if kind == "labels+intensity" else None,
        end_inside=end_inside,
        end_inside_voxels=end_voxels,
        oblique_deg=oblique,
    )


def feature_params(seed: int, params: PhantomParams) -> dict:
    """A feature draw's phantom parameters (a stream of its own: the rest of the draw
    stays as it was): ``corners`` and ``corner_sharpness`` from :data:`RANGES`, and
    ``vertices_min``/``max`` such that a mesh has :data:`RANGES` ``vertices_around``
    vertices round its outer wall (the phantom's meshes put sqrt(n aspect) round it)."""
    rng = np.random.default_rng([seed, 72, 4])
    low, high = RANGES["corners"]
    around = _uniform(rng, "vertices_around")
    aspect = np.pi * (params.radius_inlet_mm + params.radius_outlet_mm) / params.length_mm
    vertices = int(round(around**2 / aspect))
    return {
        "corners": int(rng.integers(low, high + 1)),
        "corner_sharpness": _uniform(rng, "corner_sharpness"),
        "vertices_min": vertices,
        "vertices_max": vertices,
    }


def speckled_params(seed: int, voxel_side_um: float) -> tuple[dict, TextureParams]:
    """A speckled draw's motion (``stretch``, ``twist_deg``: the phantom's) and look (a
    stream of its own: the rest of the draw stays as it was), from :data:`RANGES`
    ``speckled_*``: a fully developed speckle carried by the tissue and renewed as it
    moves, the texture's grain in voxels of ``voxel_side_um``."""
    rng = np.random.default_rng([seed, 72, 6])
    motion = {
        "stretch": _uniform(rng, "speckled_slide"),
        "twist_deg": _uniform(rng, "speckled_twist_deg"),
    }
    texture = TextureParams(
        blob_um=_uniform(rng, "speckled_grain_voxels") * voxel_side_um,
        contrast=_uniform(rng, "speckled_contrast"),
        depth_sigma=_uniform(rng, "depth_sigma"),
        speckle=_uniform(rng, "speckled_speckle"),
        attenuation_mm=_uniform(rng, "attenuation_mm"),
        speckle_decorrelation_um=_uniform(rng, "speckled_decorrelation_voxels") * voxel_side_um,
    )
    return motion, texture


def cushion_params(seed: int, params: PhantomParams, kind: str) -> dict:
    """A cushion draw's phantom parameters (a stream of its own: the rest of the draw
    stays as it was): the lumen's aspect expanded and contracted, its major axis's
    angle and the stretch where the cushions act, from :data:`RANGES`. The contracted
    aspect at or below 0 closes the lumen over part of the stretch and beat; a mesh
    draw's lumen is then meshed from voxels in every frame (``lumen_voxel_mm``), in
    pieces where closed, as a lab's mesh of its segmentation is."""
    rng = np.random.default_rng([seed, 72, 5])
    share = _uniform(rng, "cushion_stretch")
    start = float(rng.uniform(0.1, 0.9 - share)) * params.length_mm
    out = {
        "cushion_aspect_expanded": _uniform(rng, "cushion_aspect_expanded"),
        "cushion_aspect_contracted": _uniform(rng, "cushion_aspect_contracted"),
        "cushion_deg": float(rng.uniform(0.0, 180.0)),
        "cushion_from_mm": start,
        "cushion_to_mm": start + share * params.length_mm,
        "cushion_taper_mm": _uniform(rng, "cushion_taper_mm"),
    }
    lumen_voxel_mm = _uniform(rng, "cushion_lumen_voxel_mm")
    if kind == "meshes" and out["cushion_aspect_contracted"] <= 0:
        out["lumen_voxel_mm"] = lumen_voxel_mm
    return out


def front_params(seed: int, period_ms: float) -> dict:
    """A wave-front draw's phantom parameters (a stream of its own: the rest of the
    draw stays as it was): ``helix_starts`` (-2, -1, 1 or 2 in :data:`HELIX_SHARE` of
    the draws, else 0), and a front that comes first at ``side_deg`` (any angle) and
    reaches the far side ``side_lag_ms`` later (a share :data:`RANGES`
    ``side_lag_share`` of the period) in every draw without a helix and in
    :data:`HELIX_AND_SIDE_SHARE` of those with one."""
    rng = np.random.default_rng([seed, 72, 2])
    helix = int(rng.choice([-2, -1, 1, 2])) if rng.random() < HELIX_SHARE else 0
    side = helix == 0 or rng.random() < HELIX_AND_SIDE_SHARE
    lag = _uniform(rng, "side_lag_share") * period_ms
    angle = float(rng.uniform(0.0, 360.0))
    return {
        "helix_starts": helix,
        "side_lag_ms": lag if side else 0.0,
        "side_deg": angle if side else 0.0,
    }


def write_scenario(
    scenario: Scenario, out: str | Path, *, real_shape=None, real_scale_to_mm: float = 1.0
) -> Path:
    """``scenario`` as a dataset folder ``out`` (which must not exist or be empty):
    meshes (:func:`~oftimg.synthetic.phantom.write_phantom`) or label volumes,
    probability maps, intensity (:func:`~oftimg.synthetic.labels.write_label_phantom`,
    then the segmentation's systematic error, defects, values and file format); for
    kind "real", the static tube ``real_shape`` (a mesh file, coordinates times
    ``real_scale_to_mm`` in mm) animated and remeshed in every frame
    (:func:`~oftimg.synthetic.animate.write_animation`); with ``truth.json`` and
    ``scenario.json``. Returns the folder."""
    out = Path(out)
    sc = scenario
    if sc.kind == "real":
        _animated(sc, out, real_shape, real_scale_to_mm)
    elif sc.kind == "meshes":
        write_phantom(out, sc.phantom)
    else:
        seg = sc.segmentation
        probabilities = sc.kind == "probabilities"
        write_label_phantom(
            out,
            sc.phantom,
            sc.voxel_um,
            noise=seg.probability_noise if probabilities else seg.flip,
            probabilities=probabilities,
            intensity=sc.kind == "labels+intensity",
            texture=sc.texture,
            islands=seg.islands,
            oblique_deg=sc.oblique_deg,
        )
        if sc.end_inside:
            _ending_inside(out, sc.end_inside, sc.end_inside_voxels, sc.voxel_um)
        if not probabilities:
            _segmented(out, seg, sc.voxel_um)
    (out / "scenario.json").write_text(json.dumps(sc.as_dict(), indent=1))
    return out


def _animated(sc: Scenario, out: Path, shape, scale_to_mm: float) -> None:
    """Kind "real": the static tube ``shape`` animated as ``sc.animation`` says, its
    wave's speed in tube lengths a second (the shape's centre line's length)."""
    from ..io.tube import load_tube
    from .animate import Animation, axial_coordinates, write_animation

    if shape is None:
        raise ValueError("a real-shape draw needs the static tube's mesh file (real_shape)")
    tube = load_tube(shape, unit_scale=scale_to_mm)
    length_mm = float(axial_coordinates(tube.V, tube.F, tube.inlet, tube.outlet)[2][-1])
    a = sc.animation
    write_animation(
        shape,
        out,
        Animation(
            speed_mm_s=a["speed_lengths_s"] * length_mm,
            amplitude=a["amplitude"],
            period_ms=a["period_ms"],
            n_frames=a["n_frames"],
            twist_deg=a["twist_deg"],
            shortening=a["shortening"],
        ),
        scale_to_mm=scale_to_mm,
        do_remesh=True,
        seed=sc.seed,
    )


# background between the tube's end inside the volume and the volume's face
END_GAP_VOXELS = 3


def volume_offset_um(scenario_json: dict) -> np.ndarray:
    """Where the phantom's volume origin lies in the dataset's volume (um, x y z): the
    voxels added before the face where the tube ends inside (0 when none)."""
    end = scenario_json.get("end_inside")
    if not end:
        return np.zeros(3)
    axis = {"outlet": 0, "inlet": 1}[end]  # the outlet's face x = 0, the inlet's y = 0
    offset = np.zeros(3)
    offset[axis] = (scenario_json["end_inside_voxels"] + END_GAP_VOXELS) * scenario_json[
        "voxel_um"
    ][axis]
    return offset


def _ending_inside(folder: Path, end: str, voxels: int, voxel_um) -> None:
    """Every volume of ``folder`` (labels, probabilities, intensity; TIFF per frame,
    (z, y, x)) made to hold the tube going on ``voxels`` past the window's plane at
    ``end`` (its face's slice repeated: the tube goes on straight, as it leaves the
    window) and then ending, ``END_GAP_VOXELS`` of background before the volume's
    face; meta.json's "ends" cut it at the window's plane again (and at the other
    end's face). The phantom's coordinates then lie ``volume_offset_um`` further."""
    import tifffile

    axis = {"outlet": 2, "inlet": 1}[end]  # (z, y, x): x = 0 the outlet's face
    for path in sorted(folder.glob("**/*.tif")):
        volume = tifffile.imread(path)
        face = np.take(volume, [0], axis=axis)
        gap = np.zeros_like(face).repeat(END_GAP_VOXELS, axis=axis)
        if path.parent.name == "intensity":  # OCT's background, not black
            gap[...] = np.median(np.take(volume, [-1], axis=axis))
        tifffile.imwrite(
            path,
            np.concatenate([gap, face.repeat(voxels, axis=axis), volume], axis=axis),
            compression="zlib",
        )
    offset = volume_offset_um(
        {"end_inside": end, "end_inside_voxels": voxels, "voxel_um": list(voxel_um)}
    )
    faces = {
        "inlet": {"point": [0.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0]},
        "outlet": {"point": [0.0, 0.0, 0.0], "normal": [1.0, 0.0, 0.0]},
    }
    faces[end]["point"] = offset.tolist()
    meta = json.loads((folder / "meta.json").read_text())
    meta["ends"] = [faces["inlet"], faces["outlet"]]
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))


def _segmented(folder: Path, seg: Segmentation, voxel_um) -> None:
    """The label phantom in ``folder`` given the segmentation's systematic error and
    defects, written with its values and in its file format (meta.json to match)."""
    import tifffile

    from ..io.label_dataset import DEFAULT_LABEL_IDS

    frames = sorted((folder / "labels").glob("*.tif"))
    table = np.zeros(256, np.uint8)
    for layer, value in seg.values.items():
        table[DEFAULT_LABEL_IDS[layer]] = value
    volumes = []
    for t, path in enumerate(frames):
        labels = tifffile.imread(path)
        if seg.systematic is not None:
            labels = grown(labels, DEFAULT_LABEL_IDS[seg.systematic[0]], seg.systematic[1])
        if t in seg.defects:
            labels = inject(labels, seg.defects[t])
        volumes.append(table[labels])
        path.unlink()
    meta = json.loads((folder / "meta.json").read_text())
    meta["labels"] = dict(seg.values)
    # the order of the files' axes where they name none (an ImageJ TIFF and NIfTI do)
    meta.pop("axes", None)
    meta.update(
        {"tif": {"axes": "zyx"}, "npy": {"axes": "zyx"}, "zarr": {"axes": "tzyx"}}.get(
            seg.file_format, {}
        )
    )
    _write_labels(folder / "labels", volumes, seg.file_format, voxel_um, [p.stem for p in frames])
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))


def grown(labels: np.ndarray, value: int, voxels: int) -> np.ndarray:
    """``labels`` with the region of ``value`` grown by one voxel (``voxels`` +1: into
    the layers around it and the background, 6-connected) or shrunk by one (-1: each
    of its boundary voxels given the largest label among its neighbours outside it:
    the layer inside it before the background)."""
    from scipy import ndimage

    region = labels == value
    six = ndimage.generate_binary_structure(3, 1)
    out = labels.copy()
    if voxels > 0:
        out[ndimage.binary_dilation(region, six) & ~region] = value
        return out
    rim = region & ~ndimage.binary_erosion(region, six, border_value=1)
    other = np.where(region, 0, labels).astype(np.int16)
    neighbour = ndimage.maximum_filter(np.where(region, -1, other), footprint=six, mode="nearest")
    out[rim] = np.maximum(neighbour[rim], 0)
    return out


def _write_labels(folder: Path, volumes: list, file_format: str, voxel_um, stems) -> None:
    """The frames ``volumes`` ((z, y, x) each) into ``folder`` as ``file_format``:
    per-frame TIFF, NumPy or NIfTI files (named ``stems``), or one 4-D ImageJ TIFF or
    zarr array."""
    dx, dy, dz = voxel_um
    if file_format == "tif":
        import tifffile

        for stem, v in zip(stems, volumes):
            tifffile.imwrite(folder / f"{stem}.tif", v, compression="zlib")
    elif file_format == "tif4d":
        import tifffile

        tifffile.imwrite(
            folder / "labels.tif",
            np.stack(volumes),
            imagej=True,
            resolution=(1 / dx, 1 / dy),
            metadata={"spacing": dz, "unit": "um", "axes": "TZYX"},
        )
    elif file_format == "npy":
        for stem, v in zip(stems, volumes):
            np.save(folder / f"{stem}.npy", v)
    elif file_format == "nii":
        import nibabel

        for stem, v in zip(stems, volumes):
            image = nibabel.Nifti1Image(v.transpose(2, 1, 0), np.diag([dx, dy, dz, 1.0]))
            image.header.set_xyzt_units("micron")
            nibabel.save(image, folder / f"{stem}.nii.gz")
    elif file_format == "zarr":
        import zarr

        zarr.save_array(str(folder / "labels.zarr"), np.stack(volumes))
    else:
        raise ValueError(f"file_format must be one of {', '.join(FORMATS)}, found {file_format!r}")
