"""Figures of the studies (PNG, matplotlib's Agg backend: no display needed).

Errors are drawn in the paper's units: deg for joints 1 and 2, mm for joint 3 and the tool tip.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from studies.common.evaluation import JOINT_HEADERS, to_report_units  # noqa: E402

MAX_PLOT_POINTS = 2000
"""Samples drawn per curve; longer series are thinned evenly (the figure cannot show more)."""


def _thin(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, MAX_PLOT_POINTS)).astype(int))


def _save(figure, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


def error_over_time(time_s: np.ndarray, truth: np.ndarray, estimates: Mapping[str, np.ndarray],
                    path: Path, title: str) -> Path:
    """Joint errors (estimate - truth) over time, one row per method, one column per joint.

    Parameters
    ----------
    time_s : (N,) s; truth : (N, 3) SI; estimates : method label -> (N, 3) SI.
    """
    if not estimates:
        raise ValueError("error_over_time needs at least one estimate")
    rows = _thin(len(time_s))
    minutes = (np.asarray(time_s)[rows] - time_s[0]) / 60.0
    labels = list(estimates)
    figure, axes = plt.subplots(len(labels), 3, figsize=(13, 1.6 * len(labels) + 0.8), sharex=True,
                                squeeze=False)
    for r, label in enumerate(labels):
        error = to_report_units(np.asarray(estimates[label])[rows] - np.asarray(truth)[rows])
        for j in range(3):
            ax = axes[r, j]
            ax.plot(minutes, error[:, j], lw=0.6, color=f"C{r % 10}")
            ax.axhline(0.0, color="0.6", lw=0.5)
            if r == 0:
                ax.set_title(JOINT_HEADERS[j].replace("Joint", "Error, joint"), fontsize=9)
            if j == 0:
                ax.set_ylabel(label, fontsize=8, rotation=0, ha="right", va="center")
            ax.tick_params(labelsize=7)
    for j in range(3):
        axes[-1, j].set_xlabel("time (min)", fontsize=8)
    figure.suptitle(title, fontsize=10)
    figure.tight_layout(rect=(0, 0, 1, 0.98))
    return _save(figure, path)


def method_bars(values: Mapping[str, Sequence[float | None]], headers: Sequence[str], path: Path, title: str,
                published: Mapping[str, Sequence[float | None]] | None = None, log_scale: bool = True) -> Path:
    """Horizontal bars, one panel per column (joint, axis, timing), one bar per method.

    ``published`` draws the paper's values as hatched bars beside the simulated ones (same labels).
    """
    labels = list(values)
    published = published or {}
    figure, axes = plt.subplots(1, len(headers), figsize=(4.2 * len(headers), 0.32 * len(labels) + 2.2),
                                squeeze=False)
    positions = np.arange(len(labels))
    any_published = False
    for j, header in enumerate(headers):
        ax = axes[0, j]
        sim = [np.nan if values[m][j] is None else values[m][j] for m in labels]
        pub = [np.nan if published.get(m) is None or published[m][j] is None else published[m][j] for m in labels]
        has_pub = bool(np.isfinite(pub).any())
        any_published |= has_pub
        height = 0.4 if has_pub else 0.7
        ax.barh(positions - (height / 2 if has_pub else 0.0), sim, height=height, color="C0", label="simulated here")
        if has_pub:
            ax.barh(positions + height / 2, pub, height=height, color="white", edgecolor="C3", hatch="///",
                    label="published")
        ax.set_yticks(positions)
        ax.set_yticklabels(labels if j == 0 else [""] * len(labels), fontsize=8)
        ax.invert_yaxis()
        ax.set_title(header, fontsize=9)
        if log_scale:
            ax.set_xscale("log")
        ax.tick_params(labelsize=7)
        ax.grid(axis="x", which="both", alpha=0.3)
    if any_published:
        handles, names = next(ax.get_legend_handles_labels() for ax in axes[0]
                              if len(ax.get_legend_handles_labels()[0]) == 2)
        figure.legend(handles, names, loc="lower center", ncol=2, fontsize=8)
    figure.suptitle(title, fontsize=10)
    figure.tight_layout(rect=(0, 0.06 if any_published else 0, 1, 1))
    return _save(figure, path)


def lines_with_spread(x: Sequence[float], series: Mapping[str, tuple[np.ndarray, np.ndarray]],
                      headers: Sequence[str], path: Path, title: str, xlabel: str,
                      log_scale: bool = False, xticklabels: Sequence[str] | None = None) -> Path:
    """Mean +- standard deviation of each series against x, one panel per column.

    ``series``: label -> (mean (len(x), n_columns), std (len(x), n_columns)).
    """
    figure, axes = plt.subplots(1, len(headers), figsize=(4.4 * len(headers), 3.4), squeeze=False)
    x = np.asarray(x, dtype=float)
    for j, header in enumerate(headers):
        ax = axes[0, j]
        for k, (label, (mean, std)) in enumerate(series.items()):
            mean, std = np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
            ax.errorbar(x, mean[:, j], yerr=std[:, j], marker="o", ms=3, lw=1, capsize=2, label=label,
                        color=f"C{k % 10}")
        ax.set_title(header, fontsize=9)
        ax.set_xlabel(xlabel, fontsize=8)
        if xticklabels is not None:
            ax.set_xticks(x)
            ax.set_xticklabels(xticklabels, fontsize=7, rotation=30)
        if log_scale:
            ax.set_yscale("log")
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    return _save(figure, path)


def grouped_bars(groups: Sequence[str], series: Mapping[str, np.ndarray], headers: Sequence[str], path: Path,
                 title: str, log_scale: bool = True) -> Path:
    """Bars grouped by ``groups`` (x), one bar per series; ``series``: label -> (len(groups), n_columns)."""
    figure, axes = plt.subplots(1, len(headers), figsize=(4.6 * len(headers), 3.6), squeeze=False)
    positions = np.arange(len(groups))
    width = 0.8 / max(len(series), 1)
    for j, header in enumerate(headers):
        ax = axes[0, j]
        for k, (label, values) in enumerate(series.items()):
            values = np.asarray(values, dtype=float)
            ax.bar(positions + (k - (len(series) - 1) / 2) * width, values[:, j], width=width, label=label,
                   color=f"C{k % 10}")
        ax.set_xticks(positions)
        ax.set_xticklabels(groups, fontsize=7, rotation=30)
        ax.set_title(header, fontsize=9)
        if log_scale:
            ax.set_yscale("log")
        ax.tick_params(labelsize=7)
        ax.grid(axis="y", which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    return _save(figure, path)
