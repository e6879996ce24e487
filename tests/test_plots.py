"""What the study figures promise a reader, checked on the drawn figures (no eyes needed).

Bar charts: a linear value axis from 0, each bar's value written on it, the paper's value marked,
a broken axis (not a log axis) when one bar dwarfs the rest; every value axis with its unit; one
font size.
"""

from __future__ import annotations

import re

import matplotlib.text
import numpy as np
import pytest
from matplotlib.collections import LineCollection
from matplotlib.patches import Rectangle

from studies.common import plots
from studies.common.evaluation import CARTESIAN_HEADERS, JOINT_HEADERS

UNIT = re.compile(r"\((deg|mm|s|us|min)\)$")
LABELS = ["Raw (motor encoders)", "Fixed offset", "Linear regression", "DNN", "UKF"]
VALUES = {"Raw (motor encoders)": [1.93, 7.93, 11.7], "Fixed offset": [0.857, 1.11, 0.486],
          "Linear regression": [0.214, 0.288, 0.239], "DNN": [0.215, 0.248, 0.179], "UKF": [None, None, None]}
PAPER = {"Linear regression": (0.2, 0.3, 0.25), "DNN": (0.104, 0.120, 0.118)}


@pytest.fixture
def drawn(monkeypatch):
    """The figures the plot functions draw (they are saved as usual, then kept for inspection)."""
    figures = []
    save = plots._save

    def keep(figure, path):
        figures.append(figure)
        return save(figure, path)

    monkeypatch.setattr(plots, "_save", keep)
    return figures


def _bars(ax) -> list[Rectangle]:
    return [p for p in ax.patches if isinstance(p, Rectangle)]


def _value_texts(figure) -> list[matplotlib.text.Text]:
    return [t for t in figure.findobj(matplotlib.text.Text) if t.get_gid() == plots.VALUE_GID]


def _value_axes(figure) -> list:
    """The lowest axis of each column (the one carrying the value label)."""
    return [ax for ax in figure.axes if ax.get_ylabel()]


def _check_common(figure, n_columns: int) -> None:
    assert all(ax.get_yscale() == "linear" for ax in figure.axes)
    labelled = _value_axes(figure)
    assert len(labelled) == n_columns
    for ax in labelled:
        assert ax.get_ylim()[0] == 0.0
        assert UNIT.search(ax.get_ylabel()), ax.get_ylabel()
    sizes = {round(t.get_fontsize(), 3) for t in figure.findobj(matplotlib.text.Text)
             if t.get_text() and t.get_visible()}
    assert sizes == {plots.FONT_SIZE}


def test_method_bars_write_each_value_and_mark_the_papers(drawn, tmp_path):
    path = plots.method_bars(VALUES, JOINT_HEADERS, tmp_path / "bars.png", "RMSE per joint", published=PAPER)
    assert path.stat().st_size > 0
    (figure,) = drawn
    _check_common(figure, 3)
    assert [ax.get_ylabel() for ax in _value_axes(figure)] == ["RMSE (deg)", "RMSE (deg)", "RMSE (mm)"]

    texts = _value_texts(figure)
    expected = [v for label in LABELS for v in VALUES[label]]
    assert sorted(t.get_text() for t in texts) == sorted(plots.format_value(np.nan if v is None else v)
                                                        for v in expected)
    for text in texts:
        if text.get_text() != "n/a":
            value = float(text.get_text())
            assert min(abs(value - v) / v for v in expected if v is not None) < 5e-3

    # every finite value is the height of a bar of the lowest axis of its column, at its method's x
    for j, ax in enumerate(_value_axes(figure)):
        heights = {round(b.get_x() + b.get_width() / 2): b.get_height() for b in _bars(ax)}
        for i, label in enumerate(LABELS):
            assert heights[i] == pytest.approx(0.0 if VALUES[label][j] is None else VALUES[label][j])

    marks = [c for c in figure.findobj(LineCollection) if c.get_gid() == plots.PAPER_GID]
    marked = sorted({round(float(s[0][1]), 6) for c in marks for s in c.get_segments()})
    assert marked == sorted({round(v, 6) for values in PAPER.values() for v in values})
    for c in marks:
        for (x0, y0), (x1, y1) in c.get_segments():
            assert y0 == y1 and x1 - x0 == pytest.approx(0.7)      # across its bar
    legend = [t.get_text() for t in figure.legends[0].get_texts()]
    assert legend == [plots.BAR_LABEL, plots.PAPER_LABEL]


def test_a_bar_that_dwarfs_the_rest_breaks_the_axis_instead_of_a_log_scale(drawn, tmp_path):
    plots.method_bars(VALUES, JOINT_HEADERS, tmp_path / "bars.png", "RMSE per joint", published=PAPER)
    (figure,) = drawn
    # joint 1 (1.93 against 0.86): one axis; joints 2 and 3 (7.93 and 11.7 against about 1): two
    assert len(figure.axes) == 5
    for j, big in ((1, 7.93), (2, 11.7)):
        lower = _value_axes(figure)[j]
        (upper,) = [ax for ax in figure.axes if ax is not lower and ax.get_shared_x_axes().joined(ax, lower)
                    and ax.get_position().y0 >= lower.get_position().y1
                    and ax.get_position().y0 - lower.get_position().y1 < 0.05]
        assert lower.get_ylim()[1] < big and upper.get_ylim()[0] < big < upper.get_ylim()[1]
        assert lower.get_ylim()[1] <= upper.get_ylim()[0]
        small = max(v[j] for v in VALUES.values() if v[j] is not None and v[j] < big)
        assert small < lower.get_ylim()[1] < 1.5 * small          # the small bars fill the lower panel
        label = [t for t in _value_texts(figure) if t.get_text() == plots.format_value(big)]
        assert [t.axes for t in label] == [upper]


@pytest.mark.parametrize(("values", "expected"), [
    ([3.57, 3.76, 3.61], None),                       # close values: one axis
    ([0.2, 0.25, 0.3, 11.7], (0.3, 11.7)),            # one bar dwarfs the rest
    ([0.2, 0.25, 0.3, 8.0, 11.7, 9.0], None),         # half of the bars are large: no break
    ([0.001, 0.02, 0.05, 0.5, 21.9, 160.0], (0.5, 21.9)),
    ([None, np.nan, 0.0, 1.0], None),
])
def test_axis_break(values, expected):
    assert plots.axis_break(values) == expected


def test_values_are_written_with_three_significant_digits():
    assert [plots.format_value(v) for v in (3.5712, 0.0915, 11.723, 160.4, 0.0, np.nan)] == \
        ["3.57", "0.0915", "11.7", "160", "0", "n/a"]


def test_headers_give_the_panel_title_and_the_unit():
    assert plots.split_header("Joint 3 (mm)") == ("Joint 3", "mm")
    assert plots.split_header("predict() call (us)") == ("predict() call", "us")
    assert plots.split_header("Dist") == ("Dist", None)
    assert plots.axis_label("time", "training (s)") == "time (s)"


def test_grouped_bars_label_every_bar_and_mark_the_papers(drawn, tmp_path):
    groups = ["J1", "J2", "J3"]
    rng = np.random.default_rng(3)
    series = {"DNN": rng.uniform(0.1, 0.3, (3, 3)), "Raw": rng.uniform(2.0, 12.0, (3, 3))}
    paper = {"DNN": series["DNN"] * 1.1}
    plots.grouped_bars(groups, series, JOINT_HEADERS, tmp_path / "grouped.png", "RMSE by direction", published=paper)
    (figure,) = drawn
    _check_common(figure, 3)
    texts = sorted(t.get_text() for t in _value_texts(figure))
    assert texts == sorted(plots.format_value(v) for values in series.values() for v in values.ravel())
    marks = [c for c in figure.findobj(LineCollection) if c.get_gid() == plots.PAPER_GID]
    marked = sorted({round(float(s[0][1]), 9) for c in marks for s in c.get_segments()})
    assert marked == sorted(round(v, 9) for v in paper["DNN"].ravel())


def test_timings_are_labelled_as_times(drawn, tmp_path):
    values = {"Linear regression": [0.05, 0.9, 15.0], "DNN": [160.0, 40.0, 300.0], "UKF": [0.5, 2.0, 20.0]}
    plots.method_bars(values, ["training (s)", "real-time call (us)", "predict() call (us)"],
                      tmp_path / "speed.png", "Training and inference time", quantity="time")
    (figure,) = drawn
    _check_common(figure, 3)
    assert [ax.get_ylabel() for ax in _value_axes(figure)] == ["time (s)", "time (us)", "time (us)"]
    assert not figure.legends                             # one series, no paper values: nothing to tell apart


def test_tool_tip_bars_have_one_panel_per_axis(drawn, tmp_path):
    values = {"Fixed offset": [3.76, 3.66, 3.74, 3.94], "DNN": [3.57, 3.81, 3.54, 3.92]}
    plots.method_bars(values, CARTESIAN_HEADERS, tmp_path / "tip.png", "Tool-tip RMSE")
    (figure,) = drawn
    _check_common(figure, 4)
    assert [ax.get_title() for ax in figure.axes] == ["X", "Y", "Z", "Dist"]


@pytest.mark.parametrize("log_scale", [False, True])
def test_lines_carry_units_and_readable_log_ticks(drawn, tmp_path, log_scale):
    x = [30.0, 60.0, 120.0]
    series = {"DNN": (np.array([[0.3, 0.2, 0.1]] * 3), np.full((3, 3), 0.01)),
              "Fixed offset": (np.array([[0.9, 1.1, 0.5]] * 3), np.full((3, 3), 0.05))}
    plots.lines_with_spread(x, series, JOINT_HEADERS, tmp_path / "lines.png", "RMSE against calibration time",
                            "calibration time (s)", log_scale=log_scale)
    (figure,) = drawn
    for ax in figure.axes:
        assert UNIT.search(ax.get_ylabel()) and ax.get_xlabel() == "calibration time (s)"
        if log_scale:
            assert ax.get_yscale() == "log"
            assert not any(t.get_text() for t in ax.yaxis.get_minorticklabels())
        else:
            assert ax.get_yscale() == "linear" and ax.get_ylim()[0] == 0.0
    sizes = {round(t.get_fontsize(), 3) for t in figure.findobj(matplotlib.text.Text) if t.get_text()}
    assert sizes == {plots.FONT_SIZE}


def test_error_over_time_labels_every_panel_with_its_unit(drawn, tmp_path):
    t = np.linspace(0.0, 120.0, 5000)
    truth = np.c_[np.sin(t), np.cos(t), 0.1 + 0.01 * np.sin(t)]
    estimates = {"Linear regression": truth + 1e-3, "DNN": truth - 1e-3}
    plots.error_over_time(t, truth, estimates, tmp_path / "error.png", "Joint error over time")
    (figure,) = drawn
    assert [ax.get_ylabel() for ax in figure.axes] == ["error (deg)", "error (deg)", "error (mm)"] * 2
    assert [ax.get_xlabel() for ax in figure.axes[-3:]] == ["time (min)"] * 3
    assert all(len(ax.lines[0].get_xdata()) == plots.MAX_PLOT_POINTS for ax in figure.axes)


def test_empty_inputs_are_refused(tmp_path):
    with pytest.raises(ValueError, match="at least one method"):
        plots.method_bars({}, JOINT_HEADERS, tmp_path / "x.png", "x")
    with pytest.raises(ValueError, match="at least one series"):
        plots.grouped_bars(["J1"], {}, JOINT_HEADERS, tmp_path / "x.png", "x")
