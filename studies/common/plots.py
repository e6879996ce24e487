"""Figures of the studies (PNG, matplotlib's Agg backend: no display needed).

Errors are drawn in the paper's units: deg for joints 1 and 2, mm for joint 3 and the tool tip.

Every figure follows the same rules so that it can be read without the report beside it:

* bar charts have a linear value axis starting at 0, the value written on each bar and, where the
  paper gives one, the paper's value marked on the bar (a black line);
* where one bar dwarfs the rest (a gap of more than :data:`BREAK_RATIO` between the sorted
  values), the value axis is broken in two panels so that the small bars stay readable;
* one font size (:data:`FONT_SIZE`) for every text of a figure;
* every value axis names its quantity and unit ("RMSE (deg)"); panel titles name the column
  ("Joint 1") and the figure title names what the panels show.

Column headers such as ``"Joint 1 (deg)"`` give both: the name becomes the panel title and the
unit in parentheses goes to the value axis.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

from studies.common.evaluation import JOINT_HEADERS, to_report_units  # noqa: E402

MAX_PLOT_POINTS = 2000
"""Samples drawn per curve; longer series are thinned evenly (the figure cannot show more)."""

FONT_SIZE = 9
"""Points; the size of every text in every figure (titles, labels, ticks, legends, bar values)."""

BREAK_RATIO = 4.0
"""A bar chart's value axis is broken when its sorted values jump by more than this factor."""

VALUE_GID = "bar-value"
"""``gid`` of the texts that write a bar's value (lets tests find them)."""

PAPER_GID = "paper-value"
"""``gid`` of the marks of the paper's values."""

PAPER_LABEL = "paper (published)"
BAR_LABEL = "simulated here"

_STYLE = {"font.size": FONT_SIZE, "axes.titlesize": FONT_SIZE, "axes.labelsize": FONT_SIZE,
          "xtick.labelsize": FONT_SIZE, "ytick.labelsize": FONT_SIZE, "legend.fontsize": FONT_SIZE,
          "legend.title_fontsize": FONT_SIZE, "figure.titlesize": FONT_SIZE, "figure.labelsize": FONT_SIZE,
          "axes.titleweight": "normal", "figure.titleweight": "bold"}
_HEADER = re.compile(r"^(?P<name>.*?)\s*\((?P<unit>[^()]+)\)\s*$")


def split_header(header: str) -> tuple[str, str | None]:
    """``"Joint 1 (deg)"`` -> ``("Joint 1", "deg")``; a header without a unit -> ``(header, None)``."""
    match = _HEADER.match(header)
    return (match["name"], match["unit"]) if match else (header, None)


def axis_label(quantity: str, header: str) -> str:
    """The value axis label of a column: ``axis_label("RMSE", "Joint 3 (mm)")`` -> ``"RMSE (mm)"``."""
    unit = split_header(header)[1]
    return f"{quantity} ({unit})" if unit else quantity


def format_value(value: float) -> str:
    """The text written on a bar: three significant digits, no exponent below 1000."""
    if not np.isfinite(value):
        return "n/a"
    if value == 0:
        return "0"
    if abs(value) >= 100:
        return f"{value:.0f}"
    return f"{value:.3g}"


def axis_break(values: Sequence[float], ratio: float = BREAK_RATIO) -> tuple[float, float] | None:
    """Where to break a bar chart's value axis, or None when all bars read well on one axis.

    Returns ``(low, high)``: the largest value of the lower panel and the smallest of the upper one.
    The break goes into the largest jump (by factor) of the sorted positive values, provided it
    exceeds ``ratio`` and leaves at most a third of the values above it (the few bars that dwarf
    the rest, not the rest).
    """
    finite = np.asarray([v for v in values if v is not None], dtype=float)
    positive = np.unique(finite[np.isfinite(finite) & (finite > 0)])
    if positive.size < 2:
        return None
    jumps = positive[1:] / positive[:-1]
    above = positive.size - 1 - np.arange(jumps.size)     # values above each jump
    jumps[3 * above > positive.size] = 0.0
    k = int(np.argmax(jumps))
    if jumps[k] <= ratio:
        return None
    return float(positive[k]), float(positive[k + 1])


def _thin(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, MAX_PLOT_POINTS)).astype(int))


def _save(figure, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


def _as_float(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def _text_width_pt(text: str) -> float:
    return 0.58 * len(text) * FONT_SIZE


_LABEL_GAP_PT = 3.0       # between a bar's top and its value


class _BarLayout:
    """Geometry of a bar chart in inches: one row of panels per column, a broken row taller.

    Panels are placed explicitly (not by a layout engine) so that every row has the same left
    edge and the bars of all rows line up under each other.
    """

    LEFT, RIGHT, GAP = 0.95, 0.25, 0.45
    HEIGHT, UPPER, BREAK_GAP = 1.7, 0.7, 0.1

    def __init__(self, n_slots: int, slot_in: float, broken: Sequence[bool], categories: Sequence[str],
                 tilt: bool, legend: bool):
        self.broken = list(broken)
        self.top = 0.95 if legend else 0.65
        longest = max((_text_width_pt(c) for c in categories), default=0.0) / 72.0
        self.bottom = 0.25 + (0.5 * longest + 0.15 if tilt else 0.15)
        self.width = self.LEFT + self.RIGHT + slot_in * n_slots
        rows = sum(self.HEIGHT + (self.UPPER + self.BREAK_GAP if b else 0.0) for b in self.broken)
        self.height = self.top + rows + self.GAP * (len(self.broken) - 1) + self.bottom

    def rects(self):
        """Per row: (upper rect or None, lower rect), each (left, bottom, width, height) in figure fractions."""
        w, h = self.width, self.height
        y = h - self.top
        for broken in self.broken:
            upper = None
            if broken:
                upper = (self.LEFT / w, (y - self.UPPER) / h, (w - self.LEFT - self.RIGHT) / w, self.UPPER / h)
                y -= self.UPPER + self.BREAK_GAP
            lower = (self.LEFT / w, (y - self.HEIGHT) / h, (w - self.LEFT - self.RIGHT) / w, self.HEIGHT / h)
            y -= self.HEIGHT + self.GAP
            yield upper, lower

    def header(self, figure, title: str, handles: dict) -> None:
        """The figure title and, under it, one legend line."""
        figure.suptitle(title, y=1.0 - 0.12 / self.height, va="top")
        if handles:
            labels = sorted(handles, key=lambda label: label == PAPER_LABEL)
            figure.legend([handles[label] for label in labels], labels, loc="upper center", ncol=len(labels),
                          bbox_to_anchor=(0.5, 1.0 - 0.36 / self.height), frameon=False, borderaxespad=0.0)


class _ValuePanel:
    """One column of a bar chart: a value axis from 0, broken in two when one bar dwarfs the rest."""

    def __init__(self, figure, rects, shown: np.ndarray, *, label_pt: float, sharex=None):
        upper_rect, lower_rect = rects
        self.figure, self.label_pt = figure, label_pt
        shown = shown[np.isfinite(shown)]
        top = float(shown.max()) if shown.size and shown.max() > 0 else 1.0
        split = axis_break(shown) if upper_rect is not None else None
        if split is None:
            self.upper = None
            self.lower = figure.add_axes(lower_rect, sharex=sharex)
            self.lower.set_ylim(0.0, self._room_above(self.lower, top, 0.0))
        else:
            low, high = split
            self.upper = figure.add_axes(upper_rect, sharex=sharex)
            self.lower = figure.add_axes(lower_rect, sharex=self.upper)
            lower_top = self._room_above(self.lower, low, 0.0)
            self.lower.set_ylim(0.0, lower_top)
            start = max(0.6 * high, lower_top)
            self.upper.set_ylim(start, self._room_above(self.upper, top, start))
            self._draw_break()
        for ax in self.axes:
            ax.grid(axis="y", alpha=0.3)
            ax.set_axisbelow(True)

    def _points_per_unit(self, ax) -> float:
        low, high = ax.get_ylim()
        return ax.get_position().height * self.figure.get_figheight() * 72.0 / (high - low)

    def _room_above(self, ax, highest: float, bottom: float) -> float:
        """The axis top that leaves room for a value label above ``highest``."""
        fraction = min(self.label_pt / (ax.get_position().height * self.figure.get_figheight() * 72.0), 0.6)
        return bottom + (highest - bottom) / (1.0 - fraction)

    @property
    def axes(self) -> list:
        return [self.lower] if self.upper is None else [self.upper, self.lower]

    def _draw_break(self) -> None:
        self.upper.spines["bottom"].set_visible(False)
        self.lower.spines["top"].set_visible(False)
        self.upper.tick_params(axis="x", bottom=False, labelbottom=False)
        marks = dict(marker=[(-1, -0.5), (1, 0.5)], markersize=10, linestyle="none", color="k", mec="k",
                     mew=1, clip_on=False)
        self.upper.plot([0, 1], [0, 0], transform=self.upper.transAxes, **marks)
        self.lower.plot([0, 1], [1, 1], transform=self.lower.transAxes, **marks)

    def axis_of(self, value: float):
        """The axis whose range shows the top of a bar of this height."""
        if self.upper is None or value <= self.lower.get_ylim()[1]:
            return self.lower
        return self.upper

    def label(self, text: str) -> None:
        """The value axis label, centred on the whole column, at the same place in every row."""
        self.lower.set_ylabel(text)
        box = self.lower.get_position()
        total = box.height if self.upper is None else self.upper.get_position().y1 - box.y0
        inches = self.figure.get_figwidth() * box.width
        self.lower.yaxis.set_label_coords(-0.62 / inches, 0.5 * total / box.height)

    def title(self, text: str) -> None:
        self.axes[0].set_title(text)

    def bars(self, x: np.ndarray, heights: np.ndarray, width: float, *, rotate: bool, paper: np.ndarray,
             **style) -> None:
        """Bars with their values written on top and the paper's values marked."""
        keep = np.isfinite(paper)
        for ax in self.axes:
            ax.bar(x, np.nan_to_num(heights, nan=0.0), width=width, **style)
            if keep.any():
                ax.hlines(paper[keep], x[keep] - 0.5 * width, x[keep] + 0.5 * width, colors="black",
                          linewidths=2.2, gid=PAPER_GID, label=PAPER_LABEL, zorder=4)
        for position, value, published in zip(x, heights, paper):
            finite = bool(np.isfinite(value))
            ax = self.axis_of(value) if finite else self.lower
            where = value if finite else 0.0
            if finite and np.isfinite(published) and published >= value and \
                    (published - value) * self._points_per_unit(ax) < self.label_pt and \
                    self.axis_of(published) is ax:
                where = published
            ax.annotate(format_value(value), (position, where), xytext=(0, _LABEL_GAP_PT),
                        textcoords="offset points", ha="center", va="bottom", rotation=90 if rotate else 0,
                        gid=VALUE_GID, annotation_clip=False, zorder=5)

    def categories(self, positions: np.ndarray, labels: Sequence[str], show: bool, tilt: bool) -> None:
        self.lower.set_xticks(positions)
        if show:
            self.lower.set_xticklabels(labels, rotation=30 if tilt else 0, ha="right" if tilt else "center",
                                       rotation_mode="anchor" if tilt else "default")
        else:
            self.lower.tick_params(axis="x", labelbottom=False)


def _legend_handles(axes) -> dict:
    seen: dict[str, object] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(label, handle)
    return seen


def _bar_chart(categories: Sequence[str], columns: Sequence[str], bars: Mapping[str, np.ndarray],
               paper: Mapping[str, np.ndarray], path: Path, title: str, quantity: str, *, min_slot_in: float,
               legend_bars: bool) -> Path:
    """Bars per category (x) for each series of ``bars`` (label -> (n_categories, n_columns))."""
    labels = list(bars)
    n = len(categories)
    width = 0.8 / len(labels) if len(labels) > 1 else 0.7
    slot_in = max(min_slot_in, 7.5 / n)
    texts = [format_value(v) for values in bars.values() for v in values.ravel()]
    widest = max(map(_text_width_pt, texts))
    rotate = width * slot_in * 72.0 < 1.1 * widest
    label_pt = _LABEL_GAP_PT + 2.0 + (widest if rotate else 1.25 * FONT_SIZE)
    tilt = max(_text_width_pt(c) for c in categories) > 0.9 * slot_in * 72.0
    shown = [np.concatenate([bars[lb][:, j] for lb in labels] + [paper[lb][:, j] for lb in labels])
             for j in range(len(columns))]
    has_paper = any(np.isfinite(values).any() for values in paper.values())
    layout = _BarLayout(n, slot_in, [axis_break(v) is not None for v in shown], categories, tilt,
                        legend=legend_bars or has_paper)
    positions = np.arange(n, dtype=float)
    with plt.rc_context(_STYLE):
        figure = plt.figure(figsize=(layout.width, layout.height))
        first = None
        panels = []
        for j, (header, rects) in enumerate(zip(columns, layout.rects())):
            panel = _ValuePanel(figure, rects, shown[j], label_pt=label_pt, sharex=first)
            first = first or panel.axes[0]
            for k, label in enumerate(labels):
                offset = (k - (len(labels) - 1) / 2) * width
                panel.bars(positions + offset, bars[label][:, j], width, rotate=rotate, paper=paper[label][:, j],
                           color=f"C{k % 10}", label=label)
            panel.title(split_header(header)[0])
            panel.label(axis_label(quantity, header))
            panel.categories(positions, categories, show=j == len(columns) - 1, tilt=tilt)
            panels.append(panel)
        first.set_xlim(-0.6, n - 0.4)
        handles = _legend_handles(ax for panel in panels for ax in panel.axes)
        if not legend_bars:
            handles = {label: h for label, h in handles.items() if label == PAPER_LABEL}
        layout.header(figure, title, handles)
        return _save(figure, path)


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
    row_in, gap_in, top_in, bottom_in = 1.2, 0.4, 0.6, 0.55
    height = top_in + bottom_in + len(labels) * row_in + (len(labels) - 1) * gap_in
    with plt.rc_context(_STYLE):
        # explicit margins (inches): a layout engine costs seconds on a figure of many panels
        figure, axes = plt.subplots(len(labels), 3, figsize=(13, height), sharex=True, squeeze=False)
        figure.subplots_adjust(left=0.8 / 13, right=1 - 0.2 / 13, wspace=0.9 / ((13 - 1.0 - 2 * 0.9) / 3),
                               top=1 - top_in / height, bottom=bottom_in / height, hspace=gap_in / row_in)
        for r, label in enumerate(labels):
            error = to_report_units(np.asarray(estimates[label])[rows] - np.asarray(truth)[rows])
            for j in range(3):
                ax = axes[r, j]
                ax.plot(minutes, error[:, j], lw=0.6, color=f"C{r % 10}")
                ax.axhline(0.0, color="0.6", lw=0.5)
                name, _ = split_header(JOINT_HEADERS[j])
                ax.set_title(f"{label}, {name.lower()}", loc="left")
                ax.set_ylabel(axis_label("error", JOINT_HEADERS[j]))
                ax.grid(alpha=0.3)
        for j in range(3):
            axes[-1, j].set_xlabel("time (min)")
        figure.suptitle(title, y=1.0 - 0.12 / height, va="top")
        return _save(figure, path)


def method_bars(values: Mapping[str, Sequence[float | None]], headers: Sequence[str], path: Path, title: str,
                published: Mapping[str, Sequence[float | None]] | None = None, *,
                quantity: str = "RMSE") -> Path:
    """Vertical bars, one panel per column (joint, axis, timing), one bar per method.

    Parameters
    ----------
    values : method label -> one value per column (None: not available), in the columns' units.
    headers : column headers with their unit in parentheses, e.g. ``"Joint 1 (deg)"``.
    published : method label -> the paper's values (same layout), drawn as a black line on the bar.
    quantity : what the values are, for the value axis label ("RMSE", "time"...).
    """
    labels = list(values)
    if not labels:
        raise ValueError("method_bars needs at least one method")
    published = published or {}
    missing = np.full(len(headers), np.nan)
    sim = np.array([_as_float(values[m]) for m in labels]).reshape(len(labels), len(headers))
    pub = np.array([_as_float(published[m]) if published.get(m) is not None else missing for m in labels])
    return _bar_chart(labels, headers, {BAR_LABEL: sim}, {BAR_LABEL: pub.reshape(sim.shape)}, path, title,
                      quantity, min_slot_in=0.8, legend_bars=bool(np.isfinite(pub).any()))


def lines_with_spread(x: Sequence[float], series: Mapping[str, tuple[np.ndarray, np.ndarray]],
                      headers: Sequence[str], path: Path, title: str, xlabel: str,
                      log_scale: bool = False, xticklabels: Sequence[str] | None = None, *,
                      quantity: str = "RMSE") -> Path:
    """Mean +- standard deviation of each series against x, one panel per column.

    Parameters
    ----------
    series : label -> (mean (len(x), n_columns), std (len(x), n_columns)), in the columns' units.
    headers : column headers with their unit in parentheses.
    xlabel : the x quantity with its unit, e.g. ``"calibration time (s)"``.
    log_scale : logarithmic value axis (for series spanning decades), labelled 1-2-3-5 per decade.
    quantity : what the values are, for the value axis label.
    """
    x = np.asarray(x, dtype=float)
    with plt.rc_context(_STYLE):
        figure, axes = plt.subplots(1, len(headers), figsize=(4.4 * len(headers), 3.8), squeeze=False,
                                    layout="constrained")
        for j, header in enumerate(headers):
            ax = axes[0, j]
            for k, (label, (mean, std)) in enumerate(series.items()):
                mean, std = np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
                ax.errorbar(x, mean[:, j], yerr=std[:, j], marker="o", ms=3, lw=1, capsize=2, label=label,
                            color=f"C{k % 10}")
            ax.set_title(split_header(header)[0])
            ax.set_xlabel(xlabel)
            ax.set_ylabel(axis_label(quantity, header))
            if xticklabels is not None:
                ax.set_xticks(x)
                ax.set_xticklabels(xticklabels, rotation=30, ha="right")
            if log_scale:
                ax.set_yscale("log")
                ax.yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 3.0, 5.0)))
                ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
                ax.yaxis.set_minor_formatter(NullFormatter())
            else:
                ax.set_ylim(bottom=0.0)
            ax.grid(alpha=0.3)
        handles = _legend_handles([axes[0, 0]])
        figure.legend(list(handles.values()), list(handles), loc="outside lower center",
                      ncol=min(len(handles), 6), frameon=False)
        figure.suptitle(title)
        return _save(figure, path)


def grouped_bars(groups: Sequence[str], series: Mapping[str, np.ndarray], headers: Sequence[str], path: Path,
                 title: str, published: Mapping[str, np.ndarray] | None = None, *,
                 quantity: str = "RMSE") -> Path:
    """Bars grouped by ``groups`` (x), one bar per series, one panel per column.

    Parameters
    ----------
    series : label -> (len(groups), n_columns) values in the columns' units.
    headers : column headers with their unit in parentheses.
    published : label -> the paper's values (same layout), drawn as a black line on the bar.
    quantity : what the values are, for the value axis label.
    """
    if not series:
        raise ValueError("grouped_bars needs at least one series")
    published = published or {}
    shape = (len(groups), len(headers))
    data = {label: np.asarray(values, dtype=float).reshape(shape) for label, values in series.items()}
    paper = {label: np.asarray(published[label], dtype=float).reshape(shape) if label in published
             else np.full(shape, np.nan) for label in data}
    return _bar_chart(list(groups), headers, data, paper, path, title, quantity,
                      min_slot_in=0.34 * len(data) + 0.3, legend_bars=True)
