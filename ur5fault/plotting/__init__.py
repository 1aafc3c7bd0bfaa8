"""Figures: the paper's backlash figures (:mod:`.paper`), severity figures for any swept effect
(:mod:`.severity`) and one run's time series (:mod:`.run`).

Every function returns a :class:`matplotlib.figure.Figure` and takes an optional ``ax`` (``axes`` for the
multi-panel run figure) to draw into; none picks a matplotlib backend or uses pyplot, so a notebook's
inline display is left alone.  :func:`campaign_figures` makes every figure a campaign supports and says
why the others are missing; :func:`save` writes figures as PNG.
"""

from __future__ import annotations

import logging
from collections.abc import Collection
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..campaign.result import CampaignResult
from ..campaign.summary import HEALTHY, joint_feature
from ..errors import ConfigFileError, StoredResultError, Ur5FaultError
from ..seed_paper import PAPER_BACKLASH_DEG
from ._figure import check_feature, check_folder, save
from .paper import check_result, fig3_tcp_deviation, fig4_shoulder_current
from .run import run_figure
from .severity import heatmap, severity_figure

__all__ = ["FIG3_STEM", "FIG4_STEM", "FIGURE_STEMS", "campaign_figures", "fig3_tcp_deviation", "fig4_shoulder_current",
           "figure_stems", "heatmap", "drawn_and_failed", "plot_campaign", "run_figure", "save", "severity_figure"]

_log = logging.getLogger(__name__)



#: the beginnings of the file names of :func:`campaign_figures`' figures
FIGURE_STEMS = ("fig3_", "fig4_", "severity_", "heatmap_")
#: the file stems of the paper's Fig. 3 and Fig. 4 (:func:`drawn_and_failed`)
FIG3_STEM, FIG4_STEM = f"fig3_tcp_deviation_alpha{PAPER_BACKLASH_DEG:g}", "fig4_shoulder_current"


def _severity_stem(effect: str, feature: str) -> str:
    return f"severity_{effect}_{feature}"


def _heatmap_stem(effect: str, feature: str) -> str:
    return f"heatmap_{effect}_{feature}"


def _missing_note(effect: str, feature: str, n_runs: int) -> str:
    """Why an effect gets no figure of ``feature``: the feature is NaN in all its runs."""
    why = (" (the TCP deviation is measured against a healthy twin, which a sampled campaign simulates only for the "
           "fault kinds of its sample's `twins` key)" if feature.startswith("tcp_dev_") else "")
    return (f"no figure for effect '{effect}': {feature} is missing (NaN) in all {n_runs} of its runs{why}; choose "
            "another --feature, e.g. current_spike_max_A")


def figure_stems(result: CampaignResult, feature: str = "tcp_dev_max_mm") -> list[str]:
    """The file stems of the figures :func:`drawn_and_failed` would draw of ``result``, without drawing them (from
    its swept effects): what ``ur5fault plot`` would write, checked for earlier files before any work."""
    sweeps, _ = result.sweeps()
    stems = [FIG3_STEM, FIG4_STEM] if "backlash" in sweeps else []
    for effect, sweep in sweeps.items():
        if not _drawable(sweep, feature):  # no figure (drawn_and_failed says why): none to replace either
            continue
        stems += [_severity_stem(effect, feature)] + ([_heatmap_stem(effect, feature)] if sweep.per_joint else [])
    return stems


def _drawable(sweep, feature: str) -> bool:
    """Whether ``feature`` has a value in any of the sweep's runs (else its figures would be blank axes)."""
    return bool(np.isfinite(joint_feature(sweep.rows, feature)).any())


def campaign_figures(result: CampaignResult, feature: str = "tcp_dev_max_mm") -> tuple[dict[str, Figure], list[str]]:
    """Every figure the campaign supports, by file stem, and one message per figure it cannot have or could
    not draw.

    Backlash gets the paper's Fig. 3 and Fig. 4; every swept effect gets ``feature`` against its fault size
    and, when it sits on joints, a joint x size heat map of ``feature``.
    """
    figures, messages, failures = drawn_and_failed(result, feature)
    return figures, messages + failures


def drawn_and_failed(result: CampaignResult, feature: str = "tcp_dev_max_mm", skip: Collection[str] = ()
                     ) -> tuple[dict[str, Figure], list[str], list[str]]:
    """:func:`campaign_figures` with the figures the campaign cannot have (its design: nothing to draw) apart from
    those it could not draw (a run that can be neither read nor simulated again): ``(figures, cannot_have,
    failed)``. ``skip``: the paper's figures (:data:`FIG3_STEM`, :data:`FIG4_STEM`) not to draw (kept from an
    earlier plot: they do not depend on ``feature``)."""
    check_result(result, "campaign_figures")
    check_feature(feature, "campaign_figures")
    if result.features.empty:
        raise ConfigFileError(f"{result.out}: the campaign's feature table holds no runs: nothing to draw")
    values = joint_feature(result.features, feature)  # an unknown feature is an error before any work
    figures: dict[str, Figure] = {}
    messages: list[str] = []
    failures: list[str] = []
    if not np.isfinite(values).any():  # e.g. the encoder mismatch of a campaign without motor encoders
        encoders = "" if result.manifest.get("motor_encoders", True) else " (the campaign has motor_encoders: false)"
        raise ConfigFileError(f"{feature} is missing (NaN) in every run of {result.out}{encoders}: nothing to draw; "
                              "choose another --feature")
    sweeps, skipped = result.sweeps()
    messages += [f"no figure for {why}" for why in skipped.values()]
    if "backlash" in sweeps:
        for name, draw in ((FIG3_STEM, lambda: fig3_tcp_deviation(result, PAPER_BACKLASH_DEG)),
                           (FIG4_STEM, lambda: fig4_shoulder_current(result))):
            if name in skip:
                continue
            try:
                figures[name] = draw()
            except StoredResultError as exc:  # its runs can be neither read nor simulated again
                failures.append(str(exc))
            except Ur5FaultError as exc:  # the campaign holds no run the figure needs (said once for both)
                if str(exc) not in messages:
                    messages.append(str(exc))
    healthy = result.features[(result.features["fault"] == HEALTHY) & (result.features["status"] == "ok")]
    for effect, sweep in sweeps.items():
        if not _drawable(sweep, feature):  # blank axes, written as if drawn
            messages.append(_missing_note(effect, feature, len(sweep.rows)))
            continue
        figures[_severity_stem(effect, feature)] = severity_figure(sweep, feature, healthy=healthy,
                                                                  threshold_mm=result.threshold_mm)
        if sweep.per_joint:
            figures[_heatmap_stem(effect, feature)] = heatmap(sweep, feature)
    if not sweeps and not skipped:
        messages.append(f"{result.out}: the campaign sweeps no effect ({', '.join(result.swept_keys) or 'nothing'})")
    return figures, messages, failures


def plot_campaign(out: str | Path, feature: str = "tcp_dev_max_mm", plot_dir: str | Path | None = None) -> list[Path]:
    """Write :func:`campaign_figures` of the campaign in ``out`` as PNG (default ``out/plots``); return the
    paths.  Figures the campaign cannot have are logged as warnings."""
    check_folder(out, "plot_campaign: out")
    check_feature(feature, "plot_campaign")
    if plot_dir is not None:
        check_folder(plot_dir, "plot_campaign: plot_dir")
    result = CampaignResult.load(out)
    figures, messages = campaign_figures(result, feature)
    for m in messages:
        _log.warning(m)
    return save(figures, Path(plot_dir) if plot_dir is not None else result.out / "plots")
