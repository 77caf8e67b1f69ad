"""A static HTML report that opens offline from the file system (no server, no CDN)."""

from __future__ import annotations

import html
import json
import os
import re
import urllib.parse
from pathlib import Path

from . import numbers
from .style import PAGE_MM, PNG_DPI
from .units import KINDS
from .report import (
    CORRECTION,
    MEASUREMENT_COLUMNS,
    QC_COLUMNS,
    column_header,
    group_comparison,
    statistics_note,
    table1_layout,
    table_rows,
)

STYLE = """
body{font-family:system-ui,sans-serif;margin:1.5em auto;max-width:1320px;padding:0 1em;color:#222}
table{border-collapse:collapse;font-size:0.85em;margin:1em 0}
th,td{border:1px solid #ccc;padding:3px 6px;text-align:right}
th{background:#f3f3f3} td:first-child,th:first-child,td.text,th.text{text-align:left}
table.table1{font-size:0.74em} table.table1 td,table.table1 th{padding:2px 4px}
img{max-width:100%;border:1px solid #eee;margin:4px 0}
video{max-width:100%;margin:4px 0;background:#000}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(480px,1fr));gap:10px}
.grid .wide{grid-column:1/-1} figure{margin:0.5em}
.small{color:#666;font-size:0.85em} .sig{background:#fde2e2}
table.table1 th{font-weight:600} table.table1 tr>:first-child{white-space:nowrap} details{margin:0.6em 0} summary{cursor:pointer;font-weight:600}
pre{white-space:pre-wrap;overflow-wrap:anywhere}
"""

# Checks, once the page has loaded, that every picture and video could be read;
# the result lands in #oftimg-check (used by the browser test).
CHECK = """
<div id="oftimg-check" hidden>pending</div>
<script>
window.addEventListener('load', function () {
  var bad = [];
  document.querySelectorAll('img').forEach(function (i) {
    if (!i.complete || i.naturalWidth === 0) bad.push(i.getAttribute('src'));
  });
  var vids = Array.prototype.slice.call(document.querySelectorAll('video'));
  var waits = vids.map(function (v) {
    return new Promise(function (done) {
      if (v.readyState >= 1) return done();
      v.addEventListener('loadedmetadata', function () { done(); });
      v.addEventListener('error', function () { bad.push(v.getAttribute('src')); done(); });
      setTimeout(done, 4000);
    });
  });
  Promise.all(waits).then(function () {
    vids.forEach(function (v) { if (v.readyState < 1) bad.push(v.getAttribute('src')); });
    document.getElementById('oftimg-check').textContent =
      bad.length ? 'missing: ' + bad.join(', ') : 'all resources loaded';
  });
});
</script>
"""


def _fmt(x) -> str:
    """A value as a reader sees it (:mod:`~oftimg.output.numbers`): per wall or field
    "name value, ...", numbers to 3 digits, yes/no, a dash for NaN, "" for None."""
    if isinstance(x, dict):  # per wall
        return ", ".join(f"{html.escape(str(k))} {_fmt(v)}" for k, v in x.items())
    if isinstance(x, (list, tuple)):
        return ", ".join(_fmt(v) for v in x) if len(x) else "none"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if x is None:
        return ""
    if isinstance(x, (int, float)):
        return numbers.number(x)
    return html.escape(str(x))


def _scaled(x, scale: float | None):
    """``x`` (a number, or a dict of them) times ``scale``; ``scale`` None: a setting,
    written as it was set (5, not 5.00)."""
    if isinstance(x, dict):
        return {k: _scaled(v, scale) for k, v in x.items()}
    if not numbers.is_finite_number(x):
        return x
    return f"{x:g}" if scale is None else x * scale if scale != 1 else x


def _repaired(repairs: dict, shown: int = 3) -> str:
    """``"0"``, or how many files were repaired and what was done to the first few."""
    if not repairs:
        return "0"
    listed = "; ".join(f"{name}: {what}" for name, what in list(repairs.items())[:shown])
    more = (
        f"; {len(repairs) - shown} more in summary.json: validation" if len(repairs) > shown else ""
    )
    return f"{len(repairs)} ({listed}{more})"


def _table(
    rows: list[dict], cols: list[str], *, link=None, highlight=None, names: dict | None = None
) -> str:
    """Rows (dicts) as an HTML table of ``cols``, headed by ``names`` where given;
    ``link(row)`` links the first cell, ``highlight(row)`` shades a row."""
    prose = {
        c
        for c in cols
        if any(isinstance(r.get(c), str) and len(r.get(c)) > PROSE_CHARS for r in rows)
    }  # read left to right
    head = "".join(
        ('<th class="text">' if c in prose else "<th>")
        + f"{html.escape((names or {}).get(c, c))}</th>"
        for c in cols
    )
    body = []
    for r in rows:
        cells = []
        for c in cols:
            value = r.get(c)
            text = (
                numbers.p_value(value)
                if P_COLUMN.search(c) and isinstance(value, float)
                else _fmt(value)
            )
            if link and c == cols[0]:
                text = f'<a href="{html.escape(link(r))}">{text}</a>'
            cells.append(f'<td class="text">{text}</td>' if c in prose else f"<td>{text}</td>")
        cls = ' class="sig"' if highlight and highlight(r) else ""
        body.append(f"<tr{cls}>{''.join(cells)}</tr>")
    return f'<div style="overflow-x:auto"><table><tr>{head}</tr>{"".join(body)}</table></div>'


NBSP_PM = "\u00a0±\u00a0"  # "mean ± SD" kept on one line, "(n=3)" may wrap below it
WIDE_ASPECT = 2.0  # a figure wider than this over its height spans the page
PROSE_CHARS = 40  # a longer text cell is prose: left-aligned
P_COLUMN = re.compile(r"(^|_)p(_|$)")  # p_value, p_holm, least_p_cluster: 2 digits
PAGE_WIDE_PX = 0.95 * PAGE_MM / 25.4 * PNG_DPI  # ... as does one drawn the page's width
TABLE_COLUMNS_SHOWN = 10  # a wider table is cut into parts of this many, its first column in each


def _wide_table(rows: list[dict], cols: list[str], **kwargs) -> str:
    """:func:`_table` cut into parts of at most :data:`TABLE_COLUMNS_SHOWN` columns,
    each beginning with the first column (the row's name): readable on a laptop
    without scrolling sideways."""
    first, rest = cols[0], cols[1:]
    step = TABLE_COLUMNS_SHOWN - 1
    return "".join(
        _table(rows, [first] + rest[k : k + step], **kwargs) for k in range(0, len(rest), step)
    )


def _text_table(header: list[str], body: list[list[str]], *, strong_from: int) -> str:
    """A table of ready-made text cells; the rows from ``strong_from`` on in bold
    (the group rows under the embryos)."""
    head = "".join(f"<th>{html.escape(c)}</th>" for c in header)
    rows = []
    for k, row in enumerate(body):
        tag = "th" if k >= strong_from else "td"
        rows.append(
            "<tr>"
            + "".join(f"<{tag}>{html.escape(c).replace(' ± ', NBSP_PM)}</{tag}>" for c in row)
            + "</tr>"
        )
    return (
        f'<div style="overflow-x:auto"><table class="table1"><tr>{head}</tr>'
        f"{''.join(rows)}</table></div>"
    )


def _page(title: str, body: str) -> str:
    return (
        f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head>"
        f"<body>{body}{CHECK}</body></html>"
    )


def _write_new(path: Path, text: str) -> None:
    """Write ``path`` as a new file (then renamed over any old one): a page that is a
    hard link into another results folder (:func:`oftimg.output.export.link_or_copy`) is
    replaced, not written through."""
    tmp = path.with_name(path.name + ".new")
    tmp.write_text(text)
    os.replace(tmp, path)


def _warnings(summary: dict) -> list[str]:
    """The warnings of a dataset's analysis, without the dataset's path before each."""
    path = f"{(summary.get('validation') or {}).get('path')}: "
    return [text.removeprefix(path) for text in summary.get("warnings") or []]


def _shown_as(kind: str) -> tuple[str, float]:
    """A kind's unit and scale (:data:`oftimg.output.units.KINDS`), as a row below."""
    return KINDS[kind].unit, KINDS[kind].scale


# files that show a per-pixel (u, v, t) field, whose captions name the grid it is on
# the dataset page's quantities: summary.json key, what it is, unit, scale to that unit
# (None: a setting, shown as set)
QUANTITIES = [
    ("group", "group", "", 1),
    ("n_frames", "frames", "", 1),
    ("period_ms", "period of the cycle", "ms", 1),
    ("t0_frame", "input frame at t = 0 (the outer wall's smallest volume)", "", 1),
    ("expand_fraction", "expansion: share of the cycle", *_shown_as("share_of_cycle")),
    ("contract_fraction", "contraction: share of the cycle", *_shown_as("share_of_cycle")),
    ("expand_ms", "expansion time", "ms", 1),
    ("contract_ms", "contraction time", "ms", 1),
    ("tube_length_mm", "tube length (centroid line, time average)", "mm", 1),
    (
        "myocardial_volume_change",
        "myocardial volume change over the cycle",
        *_shown_as("volume_change"),
    ),
    (
        "jelly_volume_change",
        "cardiac jelly volume change over the cycle",
        *_shown_as("volume_change"),
    ),
    ("wall_thickness_median_mm", "wall thickness, median", *_shown_as("thickness")),
    ("wall_thickening", "wall thickening over the cycle (median row)", *_shown_as("thickening")),
    ("jelly_thickness_median_mm", "cardiac jelly thickness, median", *_shown_as("thickness")),
    (
        "jelly_thickening",
        "cardiac jelly thickening over the cycle (median row)",
        *_shown_as("thickening"),
    ),
    ("band_position_mm", "band (narrowest section at maximum area) from the inlet", "mm", 1),
    ("corner_count", "corners of the outer section at maximum expansion", "", 1),
    ("ridge_smoothing_ms", "ridge smoothing in time (Gaussian sigma)", "ms", None),
    ("field_smoothing_ms", "shape fields' smoothing in time (Gaussian sigma)", "ms", None),
    ("strain_smoothing_ms", "strain fields' smoothing in time (Gaussian sigma)", "ms", None),
    ("wave_synchronous_within_noise", "wave indistinguishable from a synchronous beat", "", 1),
]
SPEED_NAMES = {
    "min": "minimum of the rows",
    "max": "maximum of the rows",
    "mean": "mean of the rows",
    "std": "SD of the rows",
    "median": "median of the rows",
    "cycle": "cycle (inlet to outlet)",
}
PER_PIXEL = ("curvature", "strain", "thickness", "phase")


# what each figure and video shows, as its caption says it (the guide's list of files)
CAPTIONS = {
    "volume_over_cycle": "Volume inside each wall and of the layers between them over the "
    "aligned cycle",
    "trim_over_cycle": "The myocardium's volume and the clipping plane that keeps it constant",
    "frame_t0_contours": "The grid and the section contours at t = 0",
    "area_map_outer": "The outer wall's (v, t) area map with its ridge (maximum area) and "
    "the 75 % and one-sigma expansion masks",
    "area_derivative_outer": "The area map's Sobel-HSV derivative image (hue: direction, "
    "brightness: size) and the largest expansion and contraction "
    "rates",
    "max_area_profile": "Each wall's largest section area along the tube",
    "time_expanded": "Share of the cycle each position is expanded",
    "ridge_speed": "The ridge's time along the tube, the local wave speeds and the two-segment fit",
    "wall_thickness_map": "Myocardial wall thickness, mean around the tube, over (v, t)",
    "jelly_thickness_map": "Cardiac jelly thickness, mean around the tube, over (v, t)",
    "lumen_cushions": "The lumen's aspect ratio over (v, t) and where the cushions close it",
    "shape_pca": "Cross-section shape modes, expansion and contraction",
    "activation_outer": "The wave on the outer wall: activation times, isochrones and direction",
    "activation_inner": "The wave on the inner wall: activation times, isochrones and direction",
    "activation_lumen": "The wave on the lumen's wall: activation times, isochrones and direction",
    "wave_speed_outer": "The wave's speed on the outer wall, node by node",
    "wave_speed_inner": "The wave's speed on the inner wall, node by node",
    "wave_speed_lumen": "The wave's speed on the lumen's wall, node by node",
    "pullback_outer": "The intensity across the myocardium pulled back onto the grid, "
    "and where texture tracking could trust it",
    "area_map_cursor": "The area map with a moving time cursor",
    "outer_wall_3d_area_map": "The outer wall in 3-D coloured by its section area, beside "
    "the area map",
    "lumen_mean_curvature_3d": "The lumen in 3-D coloured by its mean curvature",
    "phase_outer_3d": "The outer wall coloured by the phase of its motion",
    "radial_curvature_outer": "Outer wall: radial curvature over (u, v), one beat",
    "radial_curvature_outer_normalized": "Outer wall: radial curvature, each node scaled "
    "to its own range over the beat",
    "radial_curvature_inner": "Inner wall: radial curvature over (u, v), one beat",
    "strain_energy_outer": "Outer wall: strain energy against t = 0, one beat",
    "strain_energy_inner": "Inner wall: strain energy against t = 0, one beat",
    "wall_thickness": "Myocardial wall thickness over (u, v), one beat",
    "jelly_thickness": "Cardiac jelly thickness over (u, v), one beat",
    "mean_curvature_lumen": "Lumen: mean curvature over (u, v), one beat",
    "surface_speed_outer": "Outer wall: the tissue's speed on the wall, one beat",
    "surface_divergence_outer": "Outer wall: the tissue's surface divergence, one beat",
    # the cohort's
    "group_area_maps": "Each group's mean outer area map (each row over its maximum) and "
    "where the groups differ",
    "group_wall_thickness_maps": "Each group's mean wall thickness map and where the groups differ",
    "group_jelly_thickness_maps": "Each group's mean cardiac jelly thickness map and where "
    "the groups differ",
    "group_strain_energy_maps": "Each group's mean outer strain energy map and where the "
    "groups differ",
    "group_max_area": "Largest outer section area along the tube, each embryo by group",
    "group_ridge_time": "The ridge's time along the tube, each embryo by group",
    "group_time_expanded": "Share of the cycle expanded along the tube, each embryo by group",
    "group_wall_thickness": "Mean wall thickness along the tube, each embryo by group",
    "group_wall_thickening": "Wall thickening over the beat along the tube, by group",
    "group_jelly_thickness": "Mean cardiac jelly thickness along the tube, by group",
    "group_jelly_thickening": "Cardiac jelly thickening over the beat along the tube, by group",
    "group_volume": "Volumes over the aligned cycle, by group",
    "group_pca_expansion": "Cross-section shape modes in expansion, one embryo per group",
    "group_pca_contraction": "Cross-section shape modes in contraction, one embryo per group",
}


def caption(stem: str, grid_note: str = "") -> str:
    """A figure's or video's caption: what it shows (:data:`CAPTIONS`), the grid a
    per-pixel field lies on, and its file name; the file name alone for one not
    listed."""
    what = CAPTIONS.get(stem)
    if what is None:
        return html.escape(stem)
    return f"{html.escape(what + _on_grid(stem, grid_note))} <code>({html.escape(stem)})</code>"


def _on_grid(stem: str, grid_note: str) -> str:
    """``", on the <grid>"`` for a figure or video of a per-pixel field, else ""."""
    return f", on the {grid_note}" if any(k in stem for k in PER_PIXEL) else ""


def png_size(path: Path) -> tuple[int, int]:
    """A PNG's (width, height) in pixels, from its header; (0, 0) if it is not one."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return 0, 0
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def provenance_line(summary: dict) -> str:
    """One line of where a dataset's numbers came from: its folder, its input files
    counted by kind, the oftimg version (the files themselves: summary.json)."""
    prov = summary.get("provenance") or {}
    counts = []
    for kind, files in (prov.get("inputs") or {}).items():  # meshes by wall, volumes as a list
        for part, listed in files.items() if isinstance(files, dict) else [(kind, files)]:
            counts.append(f"{len(listed)} {part}" + (f" {kind}" if part != kind else ""))
    counts = ", ".join(counts)
    dataset = prov.get("dataset")
    where = dataset.get("path", "") if isinstance(dataset, dict) else (dataset or "")
    version = prov.get("oftimg_version", "")
    parts = [
        f"from {where}" if where else "",
        f"input files: {counts}" if counts else "",
        f"oftimg {version}" if version else "",
    ]
    return "; ".join(p for p in parts if p) or "see summary.json"


def figure_html(path: Path, href: str, caption: str) -> str:
    """A figure of the page's grid, linked to itself at full size; a figure drawn the
    journal page's width, or over twice as wide as it is high, takes the grid's whole
    width, so that its 7-9 pt text stays readable (in one grid cell the shape modes'
    was shown at under half its size)."""
    width, height = png_size(path)
    wide = (
        ' class="wide"'
        if height and (width > WIDE_ASPECT * height or width >= PAGE_WIDE_PX)
        else ""
    )
    return (
        f'<figure{wide}><a href="{href}"><img src="{href}" alt="{html.escape(path.stem)}">'
        f'</a><figcaption class="small">{caption}</figcaption></figure>'
    )


def _wave_front_rows(fronts: dict) -> list[dict]:
    """The wave on each wall (summary.wave_fronts), as the numbers table's rows: its
    speed on the wall and along the tube, its helix angle, where it starts and where
    it is slowest; "no propagation" for a wall that moves at once."""
    rows = []
    for wall, found in fronts.items():
        if not isinstance(found, dict):
            continue
        if not found.get("propagates"):
            rows.append(
                {
                    "quantity": f"the wave on the {wall} wall",
                    "value": "no propagation (the wall moves at once, or not at all)",
                }
            )
            continue
        noise = f"activation noise SD {numbers.number(found['activation_sd_ms_median'])} ms"
        rows += [
            {
                "quantity": f"the wave on the {wall} wall: speed on the wall, median node "
                f"({noise})",
                "unit": "mm/s",
                "value": numbers.number(found["speed_mm_s"]),
            },
            {
                "quantity": f"the wave on the {wall} wall: speed along the tube (1 / median dt/ds)",
                "unit": "mm/s",
                "value": numbers.number(found["axial_speed_mm_s"]),
            },
            {
                "quantity": f"the wave on the {wall} wall: helix angle to the axis (its "
                "nodes' interquartile range about it; their median slant either "
                "way)",
                "unit": "°",
                "value": f"{numbers.number(found['helix_angle_deg'])} "
                f"({numbers.number(found['helix_angle_iqr_deg'])}; "
                f"{numbers.number(found['obliquity_deg'])})",
            },
            {
                "quantity": f"the wave on the {wall} wall: first at s; slowest at s (its speed)",
                "unit": "mm, mm/s",
                "value": f"{numbers.number(found['earliest_s_mm'])}; "
                f"{numbers.number(found['slowest_s_mm'])} "
                f"({numbers.number(found['slowest_speed_mm_s'])})",
            },
        ]
    return rows


def dataset_page(folder: Path, summary: dict) -> Path:
    """``<name>/index.html``: the numbers, every figure and every video of one dataset."""
    figs = sorted((folder / "figures").glob("*.png"))
    vids = sorted((folder / "videos").glob("*.mp4"))
    from .figures import field_grid_note

    grid_note = field_grid_note(summary)
    rows = [
        {
            "quantity": what,
            "unit": numbers.unit(unit),  # no value (no band): a dash
            "value": numbers.DASH if summary[key] is None else _scaled(summary[key], scale),
        }
        for key, what, unit, scale in QUANTITIES
        if key in summary
    ]
    rows.append(
        {
            "quantity": "grid of the per-pixel fields (curvature, thickness, strain, phase maps)",
            "value": grid_note,
        }
    )
    if summary.get("pullbacks"):
        rows.append(
            {
                "quantity": "intensity pulled back across the myocardium: pixels (u, v) "
                "and frames, share imaged (pullbacks.npz)",
                "value": summary["pullbacks"],
            }
        )
    spread = summary.get("wave_speed_noise_sd_mm_s") or {}
    band = summary.get("wave_speed_band_95_mm_s") or {}
    if summary.get("area_wave") is False:
        rows.append(
            {
                "quantity": "wave in the area map (its speeds, the expansion share)",
                "value": f"none to time: the sections' areas change by "
                f"{100 * summary['area_swing']:.2g} % over the beat (median row); "
                "the wave on the wall is below",
            }
        )
    for k, v in (summary.get("wave_speed_mm_s") or {}).items():
        if k == "rows_used":
            rows.append(
                {"quantity": "rows of the ridge whose local speed the noise resolves", "value": v}
            )
            continue
        if band.get(k) is not None:  # calibrated on the accuracy zoo: a 95 % band
            value = f"{numbers.mean_sd(v, band[k])} (95 % band)"
        else:  # the noise spread alone: ± 1 SD
            value = (
                f"{numbers.mean_sd(v, spread[k])} (noise SD)"
                if spread.get(k) and numbers.is_finite_number(spread[k])
                else numbers.mean_sd(v, None)
            )
        rows.append(
            {"quantity": f"wave speed, {SPEED_NAMES.get(k, k)}", "unit": "mm/s", "value": value}
        )
    rows += _wave_front_rows(summary.get("wave_fronts") or {})
    checks = [
        {"check": "flipped triangles in the maps (0)", "value": summary.get("flipped_triangles")},
        {
            "check": "maps re-solved with clamped weights",
            "value": summary.get("maps_with_clamped_weights"),
        },
        {
            "check": "frames whose meshes were smoothed as rough (all or none of a wall's)",
            "value": summary.get("frames_smoothed_as_rough"),
        },
        {
            "check": "frames the wave takes to cross the tube (3 or more)",
            "value": summary.get("wave_crossing_frames"),
        },
        {
            "check": "inner grid nodes at the closest point, not towards the centre (0)",
            "value": summary.get("inner_nodes_at_closest_point"),
        },
        {
            "check": "lines from the inner grid nodes that met no lumen and took its "
            "closest point (0)",
            "value": summary.get("jelly_nodes_at_closest_point"),
        },
        {
            "check": "grid nodes of the inner wall outside the outer one, of the lumen "
            "outside the inner wall, over the frames (0, 0)",
            "value": [
                summary.get("inner_nodes_outside_outer"),
                summary.get("lumen_nodes_outside_inner"),
            ],
        },
        {
            "check": "share of each curvature or thickness field's change over the "
            "cycle that is frame-to-frame noise (well under 0.25)",
            "value": {
                name: (noise or {}).get("noise_share")
                for name, noise in (summary.get("field_noise") or {}).items()
            },
        },
        {
            "check": "half the 95 % band of each curvature and thickness field at a "
            "node: its noise widened by the accuracy zoo's calibration",
            "value": {
                name: (noise or {}).get("band_95")
                for name, noise in (summary.get("field_noise") or {}).items()
            },
        },
        {
            "check": "share of each strain energy field's size by which its grid's "
            "node noise moves it (well under 0.25)",
            "value": {
                name: (noise or {}).get("error_share")
                for name, noise in (summary.get("strain_noise") or {}).items()
            },
        },
        {
            "check": "frames whose seam continues its neighbours' (a tube without one "
            "shortest seam)",
            "value": summary.get("seam_frames_continued"),
        },
        {
            "check": "tracking: how well the frames registered (material: consecutive "
            "rings, and the closure miss over one cycle before it was spread; "
            "texture: the gap between the flows' two estimates in grid steps, "
            "the share of nodes whose tissue stayed in view, the texture's "
            "median support (correlation, 0 to 1) and the share of nodes and "
            "frames that followed the shape alone, along or around)",
            "value": {k: v for k, v in (summary.get("tracking") or {}).items() if k != "grid"}
            or None,
        },
        {
            "check": "section planes still crossing (0)",
            "value": summary.get("section_planes_still_crossing"),
        },
        {
            "check": "sections measured on the projected grid ring (0)",
            "value": summary.get("sections_from_ring"),
        },
        {
            "check": "median |section volume / capped volume - 1| (about 0)",
            "value": summary.get("section_volume_error"),
        },
        {
            "check": "frames whose volume stands out, per wall (none)",
            "value": (summary.get("frame_series_checks") or {}).get("standout_frames"),
        },
        {
            "check": "last-to-first volume step / largest step (at most 1: one cycle)",
            "value": (summary.get("frame_series_checks") or {}).get("wrap_step_ratio"),
        },
        {
            "check": "frames repaired on reading, per wall (0)",
            "value": {
                wall: _repaired(s.get("repairs", {}))
                for wall, s in ((summary.get("validation") or {}).get("surfaces") or {}).items()
            },
        },
    ]
    body = [
        f'<p><a href="../index.html">cohort</a></p><h1>{html.escape(summary["name"])}</h1>',
        _table(rows, ["quantity", "value", "unit"]),
    ]
    if summary.get("warnings"):
        body += (
            ["<h2>Warnings</h2><ul>"]
            + [f"<li>{html.escape(text)}</li>" for text in _warnings(summary)]
            + ["</ul>"]
        )
    body += ["<h2>Quality checks</h2>", _table(checks, ["check", "value"])]
    if summary.get("numbers_only"):
        body.append(
            "<p>Numbers only (run with --numbers-only): no figures or videos drawn; "
            "arrays.npz, summary.json and the tables hold every number.</p><div>"
        )
    else:
        body.append('<h2>Figures</h2><div class="grid">')
        body += [figure_html(f, f"figures/{f.name}", caption(f.stem, grid_note)) for f in figs]
        body.append('</div><h2>Videos</h2><div class="grid">')
        body += [
            f'<figure><video src="videos/{v.name}" controls muted loop preload="metadata">'
            f'</video><figcaption class="small">{caption(v.stem, grid_note)}'
            "</figcaption></figure>"
            for v in vids
        ]
    body.append(
        f'</div><h2>Provenance</h2><p class="small">'
        f"{html.escape(provenance_line(summary))}</p><details><summary>every input "
        'file, the options and the timings (summary.json)</summary><pre class="small">'
        + html.escape(
            json.dumps({k: summary.get(k) for k in ("provenance", "timings_s")}, indent=1)[:20000]
        )
        + "</pre></details>"
    )
    path = folder / "index.html"
    _write_new(path, _page(summary["name"], "".join(body)))
    return path


def _page_of(name: str) -> str:
    """The link from the cohort's page to a dataset's."""
    return f"{urllib.parse.quote(name, safe='')}/index.html"


def _cohort_warnings(summaries: list[dict]) -> str:
    """The cohort page's table of every dataset's warnings (one row each)."""
    warned = [
        {"dataset": s["name"], "group": s["group"], "warning": text}
        for s in summaries
        for text in _warnings(s)
    ]
    older = [s["name"] for s in summaries if "warnings" not in s]
    text = (
        "what each dataset's analysis warned of (its page's quality checks say more)"
        if warned
        else "no dataset's analysis warned of anything"
    )
    if older:
        text += (
            f"; {', '.join(older)} analysed by an older oftimg, which did not record its warnings"
        )
    return f'<h2>Warnings</h2><p class="small">{html.escape(text, quote=False)}</p>' + (
        _table(warned, ["dataset", "group", "warning"], link=lambda r: _page_of(r["dataset"]))
        if warned
        else ""
    )


def cohort_page(
    out: Path,
    summaries: list[dict],
    run_info: dict,
    group_figs: list[Path],
    comparison: list[dict] | None = None,
    map_rows: list[dict] | None = None,
) -> Path:
    """``index.html``: cohort table, group comparison and figures, provenance;
    ``comparison``: :func:`~oftimg.output.report.group_comparison` if already made;
    ``map_rows``: :func:`~oftimg.output.report.map_comparison_rows`."""
    body = [
        "<h1>oftimg results</h1>",
        f'<p class="small">{len(summaries)} datasets; oftimg '
        f"{html.escape(str(run_info.get('oftimg_version')))}, "
        f"{_fmt(run_info.get('seconds'))} s"
        + (
            f" (gathered; the datasets' own runs took {_fmt(run_info['datasets_seconds'])} s)"
            if run_info.get("datasets_seconds") is not None
            else ""
        )
        + (
            "; numbers only (--numbers-only): no figures or videos"
            if run_info.get("numbers_only")
            else ""
        )
        + "</p>",
    ]
    comp = group_comparison(summaries) if comparison is None else comparison
    header, rows, note = table1_layout(summaries, comp)
    body += [
        '<h2>Table 1</h2><p class="small">table1.md, table1.csv; the paper\'s '
        "quantities in its units; each column is described in columns.csv</p>",
        _text_table(header, rows, strong_from=len(summaries)),
    ]
    if note:
        body.append(f'<p class="small">{html.escape(note)}</p>')
    body += [f'<p class="small">Note: {html.escape(n)}</p>' for n in run_info.get("notes", [])]
    link = {"link": lambda r: _page_of(r["name"])}
    body += [
        "<details><summary>Other measurements (cohort.csv)</summary>",
        _wide_table(
            table_rows(summaries, MEASUREMENT_COLUMNS),
            [c.name for c in MEASUREMENT_COLUMNS],
            **link,
            names={c.name: column_header(c) for c in MEASUREMENT_COLUMNS},
        ),
        "</details><details><summary>Quality checks and noise (qc.csv)</summary>",
        _wide_table(
            table_rows(summaries, QC_COLUMNS),
            [c.name for c in QC_COLUMNS],
            **link,
            names={c.name: column_header(c) for c in QC_COLUMNS},
        ),
        "</details>",
    ]
    if comp and len({s["group"] for s in summaries}) >= 2:
        ccols = [c for c in comp[0] if c not in ("table", "unit")]
        body += [
            "<details><summary>Groups, every measurement (groups.csv)</summary>"
            '<p class="small">n, mean and SD per group. '
            f"{html.escape(statistics_note(comp))} p_holm below 0.05 shaded; the other "
            "measurements and the checks are shown, not tested (no p).</p>",
            _wide_table(
                comp,
                ccols,
                highlight=lambda r: r["p_holm"] == r["p_holm"] and r["p_holm"] < 0.05,
                names={
                    **{c: c.replace("_", " ") for c in ccols},
                    "p_value": "p",
                    "p_holm": f"p ({CORRECTION})",
                },
            ),
            "</details>",
        ]
    body.append(_cohort_warnings(summaries))
    if map_rows:
        body += [
            '<h2>Where the groups differ on the maps</h2><p class="small">'
            "cohort_maps.npz: each group against the normals on the common (position, "
            "cycle) grid; p corrected over the whole map, pixel by pixel (max-statistic "
            "permutation test) and by cluster (cluster-mass permutation test, clusters of "
            f"uncorrected p &le; {run_info.get('cluster_alpha', 0.05):g}: the groups "
            "differ somewhere in a cluster, not at each of its pixels); the group map "
            "figures outline both</p>",
            _table(
                map_rows,
                list(map_rows[0]),
                highlight=lambda r: (
                    r["least_p_cluster"] is not None and r["least_p_cluster"] < 0.05
                ),
                names={
                    "least_p_pixel": "least p, pixel by pixel",
                    "least_p_cluster": "least p, by cluster",
                    **{
                        k: f"share of the map in clusters of p < {k.split('<')[1]}"
                        for k in map_rows[0]
                        if k.startswith("share_in_clusters")
                    },
                },
            ),
        ]
    if group_figs:
        body.append('<div class="grid">')
        body += [figure_html(p, p.relative_to(out).as_posix(), caption(p.stem)) for p in group_figs]
        body.append("</div>")
    body.append(
        '<h2>Run</h2><pre class="small">' + html.escape(json.dumps(run_info, indent=1)) + "</pre>"
    )
    path = out / "index.html"
    _write_new(path, _page("oftimg results", "".join(body)))
    return path
