"""Cohorts: the tables, group comparison, maps, figures and pages written for datasets
analysed together (:func:`write_cohort_outputs`, after a run) or separately and gathered
(:func:`cohort`); the checks a cohort's names and options need."""

from __future__ import annotations

import platform
import shutil
import sys
import time
import warnings
from pathlib import Path

from . import __version__
from .errors import InputError, OftimgWarning
from .io.dataset import natural_key
from .output.export import (
    COHORT_OUTPUTS,
    check_output_location,
    cohort_maps,
    link_or_copy,
    staged_output,
    write_cohort_maps,
    write_json,
)
from .output.results import read_summary, result_folders


def _check_cluster_alpha(cluster_alpha) -> None:
    """:func:`oftimg.analysis.stats.check_cluster_alpha` as an :class:`InputError`, before any work."""
    from .analysis.stats import check_cluster_alpha

    try:
        check_cluster_alpha(cluster_alpha)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _check_names(named: list[tuple[str, Path]], fix: str) -> None:
    """Each dataset's results go to ``out/<name>``: the names of ``(name, folder)``
    must differ and must not be those of the cohort's own outputs; ``fix`` says
    how to rename one."""
    seen: dict[str, Path] = {}
    for name, path in named:
        if name in COHORT_OUTPUTS:
            raise InputError(
                f"{path}: the dataset name {name!r} is that of the cohort's "
                f"own {name} in --out; {fix}"
            )
        if name in seen:
            raise InputError(
                f"{seen[name]} and {path} have the same dataset name {name!r} "
                f"(their results would go to one folder); {fix}"
            )
        seen[name] = path


def _run_info(inputs: list[Path], options: dict, started: float) -> dict:
    """What ``run.json`` records: oftimg, Python, platform, inputs, options, seconds."""
    return {
        "oftimg_version": __version__,
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "inputs": [str(Path(p).resolve()) for p in inputs],
        "options": options,
        "seconds": round(time.time() - started, 2),
    }


def write_cohort_outputs(
    folder: Path,
    summaries: list[dict],
    run_info: dict,
    *,
    cluster_alpha: float = 0.05,
    figures: bool = True,
) -> None:
    """Cohort table (csv, md), group comparison, the area maps on one grid
    (``cohort_maps.npz``, clusters formed at ``cluster_alpha``), group figures (two
    groups or more), every dataset's page and the cohort's, ``run.json``
    (``run_info`` and ``cluster_alpha``), into ``folder``, which holds each
    dataset's results in ``folder/<name>``. ``figures=False``: no group figures."""
    from .output.figures import group_figures
    from .output.html import cohort_page, dataset_page
    from .output.report import (
        field_smoothing_caveat,
        group_comparison,
        map_comparison_rows,
        smoothing_caveat,
        write_cohort_tables,
        write_groups_table,
        write_table1_markdown,
    )

    caveats = [
        c
        for c in (
            smoothing_caveat(summaries),
            field_smoothing_caveat(summaries),
            field_smoothing_caveat(summaries, "strain_smoothing_ms"),
        )
        if c
    ]
    for caveat in caveats:
        warnings.warn(caveat, OftimgWarning, stacklevel=2)
    run_info = {**run_info, "cluster_alpha": cluster_alpha}
    if caveats:
        run_info["notes"] = caveats
    write_cohort_tables(folder, summaries)
    comparison = group_comparison(summaries)
    write_table1_markdown(folder, summaries, comparison)
    write_groups_table(folder, summaries, comparison)
    maps = cohort_maps(folder, summaries, cluster_alpha=cluster_alpha)
    write_cohort_maps(folder, maps)
    group_figs = []
    if figures and len({s["group"] for s in summaries}) >= 2:
        (folder / "figures").mkdir()
        group_figs = group_figures(folder, summaries, folder / "figures", maps=maps)
    for s in summaries:
        dataset_page(folder / s["name"], s)
    write_json(folder / "run.json", run_info)
    cohort_page(folder, summaries, run_info, group_figs, comparison, map_comparison_rows(maps))


def cohort(sources, out, *, overwrite: bool = False, cluster_alpha: float = 0.05) -> Path:
    """Gather datasets analysed separately (say one cluster job each, ``oftimg run
    embryo_k --out results/embryo_k``) into one cohort in ``out``, with the tables,
    group comparison, figures and pages that :func:`run` writes for a cohort.

    Each source is one dataset's results (a folder with ``summary.json``) or a
    folder of them (a run's ``--out``). All must have been analysed with the
    same options. Their files reach ``out`` by hard links where possible (or
    copies); the sources are never written to. ``cluster_alpha`` as in :func:`run`.
    Returns ``out``.
    """
    _check_cluster_alpha(cluster_alpha)
    started = time.time()
    out = Path(out)
    pairs = sorted(
        ((read_summary(f), f) for f in result_folders(sources)),
        key=lambda sf: natural_key(sf[0]["name"]),
    )  # as run orders a cohort
    summaries, folders = [s for s, _ in pairs], [f for _, f in pairs]
    _check_names(
        [(s["name"], f) for s, f in zip(summaries, folders)],
        'analyse one again with another "name" in its meta.json',
    )
    check_output_location(out, folders, overwrite=overwrite)
    options = summaries[0]["provenance"]["options"]
    for s, f in zip(summaries[1:], folders[1:]):
        a, b = _flat(options), _flat(s["provenance"]["options"])
        differ = [
            f"{k} {a.get(k)} and {b.get(k)}"
            for k in sorted(set(a) | set(b))
            if a.get(k) != b.get(k)
        ]
        if differ:
            raise InputError(
                f"{folders[0]} and {f} were analysed with different options "
                f"({'; '.join(differ)}): a cohort compares like with like; "
                "analyse them again with the same options"
            )
    _warn_unfinished_beside(folders)
    versions = {s["provenance"]["oftimg_version"] for s in summaries}
    if len(versions) > 1:
        warnings.warn(
            f"the datasets were analysed by different oftimg versions "
            f"({', '.join(sorted(versions))})",
            OftimgWarning,
            stacklevel=2,
        )
    with staged_output(out, overwrite=overwrite) as tmp:
        for s, folder in zip(summaries, folders):
            shutil.copytree(folder, tmp / s["name"], copy_function=link_or_copy)
        run_info = _run_info(folders, options, started)
        run_info["datasets_seconds"] = _datasets_seconds(summaries)
        write_cohort_outputs(tmp, summaries, run_info, cluster_alpha=cluster_alpha)
    return out


def _datasets_seconds(summaries: list[dict]) -> float | None:
    """Seconds the datasets' own runs took (validation, analysis, writing), summed;
    None when a summary does not record them (written by an older oftimg)."""
    try:
        return round(
            sum(s["validation"]["seconds"] + s["timings_s"]["total_s"] for s in summaries), 2
        )
    except (KeyError, TypeError):
        return None


def _warn_unfinished_beside(folders: list[Path]) -> None:
    """Warn about runs that did not finish beside the gathered results (say a cluster
    job killed at its time limit): ``.<name>.finished`` folders, which
    :func:`finished_folder` removes once a run succeeds. Their datasets are not in
    the cohort."""
    unfinished = sorted(
        {
            p
            for parent in {f.parent for f in folders}
            for p in parent.glob(".*.finished")
            if p.is_dir()
        }
    )
    if unfinished:
        names = ", ".join(p.name[1 : -len(".finished")] for p in unfinished)
        warnings.warn(
            f"{unfinished[0].parent}: {len(unfinished)} run(s) into {names} did not "
            "finish (or are still going), so their datasets are not in this cohort; "
            "run them again with --resume, then gather again",
            OftimgWarning,
            stacklevel=3,
        )


def _flat(options: dict, prefix: str = "") -> dict:
    """``{"grid": {"n_u": 80}}`` -> ``{"grid.n_u": 80}``."""
    out = {}
    for key, value in options.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[prefix + key] = value
    return out
