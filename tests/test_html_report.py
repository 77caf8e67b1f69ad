"""The offline HTML report, opened in a real headless browser (Debian's chromium)."""

import html
import os
import re
import shutil
import subprocess
import urllib.parse
from pathlib import Path

import pytest

from oftimg.cli import main
from oftimg.analysis.group_maps import TESTED_MAPS

pytestmark = [pytest.mark.long, pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--allow-file-access-from-files",
    "--autoplay-policy=no-user-gesture-required",
]


@pytest.fixture(scope="module")
def cohort_out(phantom_normal, phantom_banded, tmp_path_factory, png_figures_only):
    cohort = tmp_path_factory.mktemp("cohort")
    for p in (phantom_normal, phantom_banded):
        (cohort / p.name).symlink_to(p, target_is_directory=True)
    out = tmp_path_factory.mktemp("report") / "out"
    assert main(["run", str(cohort), "--out", str(out), "--quiet"]) == 0
    return out


def local_links(page: Path) -> list[str]:
    """The files the page's links name, read as a browser reads them (percent-decoded,
    without the #fragment)."""
    text = page.read_text()
    links = re.findall(r'(?:src|href)="([^"]+)"', text)
    assert "http://" not in text and "https://" not in text  # offline: no CDN
    return [
        urllib.parse.unquote(urllib.parse.urlsplit(html.unescape(link)).path)
        for link in links
        if not link.startswith("#")
    ]


def test_every_link_resolves_and_tables_are_there(cohort_out):
    index = cohort_out / "index.html"
    text = index.read_text()
    assert "normal" in text and "banded" in text and "permutation" in text
    assert "Where the groups differ on the maps" in text
    assert "clusters of uncorrected p &le; 0.05" in text  # the default
    # area, wall and jelly thickness, strain energy
    assert text.count("<td>banded - normal</td>") == len(TESTED_MAPS) == 4
    from oftimg.output.html import CAPTIONS, caption

    for figure in sorted((cohort_out / "figures").glob("*.png")):  # each said below it
        assert figure.stem in CAPTIONS, figure.stem
        assert (
            f'<a href="figures/{figure.name}"><img src="figures/{figure.name}" '
            f'alt="{figure.stem}"></a><figcaption class="small">{caption(figure.stem)}'
            "</figcaption>"
        ) in text  # opens full size on click
    pages = [index] + sorted(cohort_out.glob("*/index.html"))
    assert len(pages) == 3
    for page in pages[1:]:
        text = page.read_text()
        assert "Quality checks" in text and "section_volume" not in text  # formatted
        assert "outer 0," in text  # flipped triangles per wall: none
        assert "frames repaired on reading, per wall (0)</td><td>outer 0, inner 0, lumen 0" in text
    for page in pages:
        for link in local_links(page):
            assert (page.parent / link).exists(), f"{page}: {link}"
    # header, rule, 2 embryos, 2 group rows, p and corrected p; a blank line and the note
    assert (cohort_out / "table1.md").read_text().count("\n") == 2 + 2 + 2 + 2 + 2
    assert (cohort_out / "groups.csv").exists()


def test_links_to_datasets_with_any_folder_name_resolve(tmp_path):
    """A dataset folder's name goes into the cohort page's links percent-encoded:
    "#" began a fragment and "%20" was read as a space, so both links were dead."""
    from oftimg.synthetic.phantom import sample_params, write_phantom

    cohort = tmp_path / "cohort é"
    names = ["embryo A (1) é#2", "b%20x"]
    for name, group in zip(names, ("normal", "banded")):
        write_phantom(
            cohort / name, sample_params(group, 1, n_frames=5, vertices_min=1500, vertices_max=1800)
        )
    out = tmp_path / "out é"
    assert main(["run", str(cohort), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    links = local_links(out / "index.html")
    assert sorted(n for n in names if f"{n}/index.html" in links) == sorted(names)
    for link in links:
        assert (out / link).exists(), link


@pytest.mark.skipif(
    CHROMIUM is None and not os.environ.get("CI"),
    reason="chromium is installed by `make test` (required in CI)",
)
@pytest.mark.parametrize("page", ["index.html", "normal/index.html"])
def test_page_loads_in_a_browser(cohort_out, page, tmp_path):
    url = (cohort_out / page).resolve().as_uri()
    profile = tmp_path / "profile"
    dom = subprocess.run(
        [
            CHROMIUM,
            *FLAGS,
            f"--user-data-dir={profile}",
            "--virtual-time-budget=8000",
            "--enable-logging=stderr",
            "--v=0",
            "--dump-dom",
            url,
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert "all resources loaded" in dom.stdout, dom.stdout[-2000:]
    console_errors = [
        line
        for line in dom.stderr.splitlines()
        if "CONSOLE" in line and ("Uncaught" in line or "Error" in line)
    ]
    assert not console_errors
    shot = tmp_path / "shot.png"
    subprocess.run(
        [
            CHROMIUM,
            *FLAGS,
            f"--user-data-dir={profile}",
            "--window-size=1200,900",
            f"--screenshot={shot}",
            url,
        ],
        capture_output=True,
        timeout=120,
    )
    import imageio.v3 as iio
    import numpy as np

    img = iio.imread(shot)
    assert img.shape[0] > 500 and img.shape[1] > 800
    assert np.asarray(img, float).std() > 10  # not blank


def test_paper_figures_script_needs_only_the_results(cohort_out, tmp_path):
    import sys

    script = Path(__file__).resolve().parent.parent / "scripts" / "paper_figures.py"
    res = subprocess.run(
        [sys.executable, str(script), str(cohort_out), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    for tag in (
        "fig04A_area_to_line",
        "fig05_radial_curvature",
        "fig08_volume_normalization",
        "fig10_ridge_time",
        "fig12_derivative",
        "fig13_lumen_mean_curvature",
    ):
        for ext in ("png", "pdf", "svg"):
            assert (tmp_path / f"{tag}_normal.{ext}").stat().st_size > 5000
    assert (tmp_path / "groups" / "group_max_area.png").exists()
    # never inside the results, which --overwrite would then refuse to replace
    inside = subprocess.run(
        [sys.executable, str(script), str(cohort_out), "--out", str(cohort_out / "paper_figures")],
        capture_output=True,
        text=True,
    )
    assert inside.returncode != 0 and "inside the results folder" in inside.stderr
    assert not (cohort_out / "paper_figures").exists()


def test_the_cohort_page_lists_each_datasets_warnings():
    """Each warning a row, without the dataset's path, linked to its page; a cohort
    without warnings says so, unless a summary from an older oftimg never recorded
    them."""
    from oftimg.output.html import _cohort_warnings

    def summary(name, warnings=None):
        s = {"name": name, "group": "normal", "validation": {"path": f"/data/{name}"}}
        return s if warnings is None else {**s, "warnings": warnings}

    text = _cohort_warnings([summary("a b", ["/data/a b: the <inner> wall ..."]), summary("c", [])])
    assert '<a href="a%20b/index.html">a b</a>' in text
    assert "<td>the &lt;inner&gt; wall ...</td>" in text and "/data/" not in text
    assert "no dataset" not in _cohort_warnings([summary("a", ["x"])])
    assert "no dataset's analysis warned of anything</p>" in _cohort_warnings([summary("c", [])])
    older = _cohort_warnings([summary("c", []), summary("old")])
    assert "no dataset's analysis warned of anything; old analysed by an older oftimg" in older
