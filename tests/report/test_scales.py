"""The static figures: cutting-only scales, joint round-off, captions, coincident laws."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from feedopt.report.data import SampleInfo
from feedopt.report.plots import (
    FIGURES,
    caption_of,
    law_style,
    plot_accel_jerk,
    plot_feed,
    plot_joint_velocity,
)
from feedopt.report.scales import air_samples, air_times, cut_range, denoise

RAPID_MM_S = 140.0


def _with_rapid(report_data, lo: int = 150, hi: int = 200):
    """The synthetic run with a rapid at 140 mm/s on samples [lo, hi) of every law (and its
    time curves, by feed), the summary stating the max cutting feed 4.23 mm/s."""
    laws = []
    for ls in report_data.laws:
        feed = ls.feed_mm_s.copy()
        feed[lo:hi] = RAPID_MM_S
        feed_t = ls.feed_t_mm_s.copy()
        feed_t[60:70] = RAPID_MM_S
        accel = ls.accel_mm_s2.copy()
        accel[60:70] = 500.0 * np.sign(np.arange(10) - 4.5)
        laws.append(replace(ls, feed_mm_s=feed, feed_t_mm_s=feed_t, accel_mm_s2=accel))
    summary = {**report_data.summary,
               "scenario": {**report_data.summary["scenario"], "max_feed_mm_s": 4.23}}
    return replace(report_data, laws=tuple(laws), summary=summary)


def test_air_from_the_feed_without_the_runs_mask(report_data) -> None:
    data = _with_rapid(report_data)
    expected = np.zeros(data.path_xyz_mm.shape[0], dtype=bool)
    expected[150:200] = True
    np.testing.assert_array_equal(air_samples(data), expected)
    assert not air_samples(report_data).any()  # the summary states no max cutting feed
    # the run's own mask wins (here: other samples)
    k = expected.size
    own = np.zeros(k, dtype=bool)
    own[10:20] = True
    info = SampleInfo(v_max_mm_s=np.full(k, 4.23), active=np.zeros(k, int),
                      constraints=("deflection",), air=own, program_line=np.zeros(k, int))
    np.testing.assert_array_equal(air_samples(replace(data, samples=info)), own)


def test_air_times_follow_the_path_samples_when_the_law_gives_its_times(report_data) -> None:
    data = _with_rapid(report_data)
    ls = data.laws[1]
    air = air_samples(data)
    # the fallback: by the timed feed
    np.testing.assert_array_equal(air_times(data, ls, air), ls.feed_t_mm_s > 4.23 * 1.001)
    # with the time at each path sample: a time is air when the last sample reached is
    t_path = np.linspace(0.0, ls.t_s[-1], air.size)
    timed = replace(ls, path_t_s=t_path)
    got = air_times(data, timed, air)
    for t, a in zip(ls.t_s, got, strict=True):
        k = max(i for i in range(air.size) if t_path[i] <= t)
        assert a == air[k]


def test_cut_range_spans_the_cutting_samples_only() -> None:
    rng = np.random.default_rng(3)
    values = [rng.normal(size=200), rng.normal(size=200) * 3]
    air = [rng.random(200) < 0.2, rng.random(200) < 0.3]
    values[0][air[0]] = 1e4  # rapids, far off
    lo, hi = cut_range(values, air)
    cut = np.concatenate([v[~a] for v, a in zip(values, air, strict=True)])
    span = cut.max() - cut.min()
    assert lo == pytest.approx(cut.min() - 0.06 * span) and hi == pytest.approx(
        cut.max() + 0.06 * span)
    assert cut_range(values, [np.zeros(200, bool)] * 2) is None  # nothing is air: autoscale
    assert cut_range(values, [np.ones(200, bool)] * 2) is None  # nothing cuts
    assert cut_range([np.array([2.0, 3.0, 90.0])], [np.array([False, False, True])],
                     from_zero=True) == (0.0, pytest.approx(3.0 + 0.06 * 3.0))


def test_feed_and_acceleration_axes_show_the_cut_not_the_rapids(report_data) -> None:
    data = _with_rapid(report_data)
    fig = plot_feed(data)
    ax_s, ax_t = [ax for ax in fig.axes if ax.get_ylabel() == "feed [mm/s]"]
    cutting = max(float(np.max(np.delete(ls.feed_mm_s, np.s_[150:200]))) for ls in data.laws)
    assert ax_s.get_ylim() == (0.0, pytest.approx(cutting * 1.06))
    assert ax_t.get_ylim()[1] < 10 and "off scale (up to 140" in ax_s.get_title(loc="right")
    # no rapid: matplotlib's own scale, nothing said
    plain = [ax for ax in plot_feed(report_data).axes if ax.get_ylabel() == "feed [mm/s]"]
    assert plain[0].get_title(loc="right") == "" and plain[0].get_ylim()[1] < 10
    acc = plot_accel_jerk(data).axes[0]
    assert acc.get_ylim()[1] < 500 and "off scale (up to 500" in acc.get_title(loc="right")
    labels = [t.get_text() for t in acc.get_legend().get_texts()]
    assert "limit +-500 (off scale)" not in labels  # no limit stated in this summary


def test_joint_round_off_is_drawn_as_zero(report_data) -> None:
    laws = []
    for ls in report_data.laws:
        qd = ls.joint_velocity_deg_s.copy()
        qd[:, 3] = 1e-13 * np.sin(np.arange(qd.shape[0]))  # A4 does not move
        laws.append(replace(ls, joint_velocity_deg_s=qd))
    data = replace(report_data, laws=tuple(laws))
    fig = plot_joint_velocity(data)
    a4 = fig.axes[3]
    assert a4.get_title() == "A4: does not move"
    curves = [ln for ln in a4.get_lines() if ln.get_label() in {ls.law for ls in data.laws}
              or "NOT verified" in ln.get_label()]
    assert curves and all(np.all(np.asarray(ln.get_ydata()) == 0.0) for ln in curves)
    assert a4.get_ylim() == pytest.approx((-0.05 * 50, 0.05 * 50))
    lim = 50.0
    v = np.array([1e-13, -4e-8, 6e-8, 1.0])
    np.testing.assert_array_equal(denoise(v, lim), [0.0, 0.0, 6e-8, 1.0])
    assert fig.legends and not any(ax.get_legend() for ax in fig.axes)  # one, outside


def test_captions_name_the_programmed_baseline(report_data) -> None:
    spec = next(s for s in FIGURES if s.key == "deflection")
    assert "the constant feed against each law" in caption_of(spec, report_data)
    laws = (replace(report_data.laws[0], law="programmed"), *report_data.laws[1:])
    text = caption_of(spec, replace(report_data, laws=laws))
    assert "the programmed feed against each law" in text and "constant" not in text
    feed = next(s for s in FIGURES if s.key == "feed")
    assert "off scale" not in caption_of(feed, report_data)
    assert "Axes scaled on the cutting moves" in caption_of(feed, _with_rapid(report_data))


def test_coincident_laws_get_their_own_dashes_and_offset_markers(report_data) -> None:
    styles = [law_style(k, 3) for k in range(3)]
    assert len({str(s["linestyle"]) for s in styles}) == 3
    assert len({s["marker"] for s in styles}) == 3
    fig = plot_feed(report_data)
    lines = [ln for ln in fig.axes[0].get_lines() if ln.get_label() in ("thesis",
                                                                         "topp (NOT verified)")]
    starts = [ln.get_markevery()[0] for ln in lines]
    assert len(lines) == 2 and starts[0] != starts[1]  # same curve, markers apart
    for ax in fig.axes:  # legends outside the data: right of the axes
        legend = ax.get_legend()
        assert legend is not None and legend.get_bbox_to_anchor().x0 > ax.bbox.x1 - 1
