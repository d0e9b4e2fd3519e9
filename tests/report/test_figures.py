"""The report's figures read like the paper's: checked on the figure objects themselves."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_hex
from matplotlib.image import AxesImage
from matplotlib.text import Text

from fingerfriction._style import FULL_WIDTH_IN, MIN_FONT_PT, OKABE_ITO
from fingerfriction.report.data import load_report_data
from fingerfriction.report.figures import (
    FIGURES,
    fig3_occupancy,
    fig4_forces,
    fig6_model,
    region_events,
    save_figure,
)
from fingerfriction.study.results import AnalysedTrial as TrialData
from fingerfriction.study.store import frames_table


@pytest.fixture(scope="module")
def data(synthetic_results):
    return load_report_data(synthetic_results[0])


def _texts(fig) -> list[Text]:
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


@pytest.mark.slow
@pytest.mark.parametrize("stem", [f[0] for f in FIGURES])
def test_every_text_at_least_7_pt_at_the_saved_size(data, stem, tmp_path):
    """Read back from the figure after it was saved (tick labels exist only once drawn)."""
    fn = dict((f[0], f[2]) for f in FIGURES)[stem]
    fig = fn(data)
    blobs = save_figure(fig, tmp_path / stem)
    texts = _texts(fig)
    assert len(texts) > 10, stem  # titles, labels, tick labels, legend entries were drawn
    small = sorted({(round(t.get_fontsize(), 2), t.get_text()[:30]) for t in texts
                    if t.get_fontsize() < MIN_FONT_PT})
    assert not small, f"{stem}: text under {MIN_FONT_PT} pt: {small[:5]}"
    # the saved size is the print size: a full-width (180 mm) figure, not a scaled-down one
    w_in, _ = fig.get_size_inches()
    assert w_in <= FULL_WIDTH_IN + 1e-9
    png_w = int.from_bytes(blobs["png"][16:20], "big")
    assert png_w <= round((FULL_WIDTH_IN + 0.1) * 150), f"{stem}: saved PNG is {png_w / 150:.2f} in wide"
    assert b"<text" in blobs["svg"], "SVG text should stay text (svg.fonttype none)"


@pytest.mark.slow
def test_line_colours_come_from_the_colour_blind_safe_palette(data):
    palette = {v.lower() for v in OKABE_ITO.values()}
    for stem, _, fn, _ in FIGURES:
        fig = fn(data)
        for ax in fig.axes:
            for line in ax.get_lines():
                if len(line.get_xdata()) > 1:
                    c = to_hex(line.get_color()).lower()
                    assert c in palette, (stem, c)


# ---------------------------------------------------------------------------------- Fig. 3


@pytest.mark.slow
def test_fig3_has_a_colour_bar_profile_and_labelled_blind_spots(data, synthetic_results):
    _, truth = synthetic_results
    fig = fig3_occupancy(data)
    bars = [ax for ax in fig.axes if getattr(ax, "_colorbar", None) is not None]
    assert len(bars) == 1
    assert "time in contact" in bars[0].get_ylabel()
    images = [im for ax in fig.axes for im in ax.get_images() if isinstance(im, AxesImage)]
    assert len(images) == len(data.surface_names)
    # the profile under the occupancy: one axes per surface plots h(x) in mm
    assert sum(ax.get_ylabel() == "h (mm)" for ax in fig.axes) == len(data.surface_names)
    # each blind spot is labelled with its width (truth: the hand-made gaps)
    labels = {t.get_text() for t in _texts(fig)}
    for a, b in truth["gaps"].values():
        assert f"{b - a:.2f} mm" in labels


def _rest_then_slide(tid="s1-bump-2mm-v080-r1", n_rest=300):
    """A trial that rests at x = -15.5 mm for ``n_rest`` frames, then slides at 80 mm/s."""
    dt = 1e-3
    x_slide = -15.5 + 80.0 * dt * np.arange(1, 400)
    x = np.concatenate([np.full(n_rest, -15.5), x_slide])
    t = dt * np.arange(x.size)
    reg = np.stack([x - 6.0, x + 6.0], axis=1)[:, None, :]
    frames = frames_table(t, x, reg)
    xg = np.round(np.arange(-13.0, 13.0 + 1e-9, 0.01), 2)
    forces = pd.DataFrame({"x_mm": xg, "F_T_N": np.zeros(xg.size)})
    return TrialData(id=tid, subject="1", surface="bump-2mm", speed_mm_s=80.0, repetition=1, frames=frames,
                     regions=reg, forces=forces)


def test_sliding_frames_leave_out_the_rest_at_touch_down():
    tr = _rest_then_slide()
    s = tr.sliding()
    x = tr.frames["x_mm"].to_numpy()
    assert not s[:300].any()  # at rest, outside the window: never counted
    assert s[(x > -12.0) & (x < 12.0)].all()  # every frame of the slide inside the window


@pytest.mark.slow
def test_fig3_has_no_step_at_the_resting_contacts_edge(data):
    """The cause of the brightness step near x = -9.6 mm: the rest at touch-down (x = -15.5 mm,
    the contact reaching 6 mm ahead) counted as contact time. Fig. 3 counts sliding frames only."""
    tr = _rest_then_slide()
    one = dataclasses.replace(data, trials=[tr])
    fig = fig3_occupancy(one)
    im = next(im for ax in fig.axes for im in ax.get_images())
    occ = np.asarray(im.get_array())[0]
    x0, x1 = im.get_extent()[:2]
    xc = np.linspace(x0, x1, occ.size + 1)[:-1] + 0.5 * (x1 - x0) / occ.size
    near = (xc > -10.5) & (xc < -8.5)  # around the resting contact's leading edge, -9.5 mm
    assert np.abs(np.diff(occ[near])).max() < 0.01  # a smooth taper, no step
    # counting every frame (the old figure) the same data shows the step
    from fingerfriction.model.blindspots import occupancy

    every = occupancy(tr.regions)
    near = (every.centers > -10.5) & (every.centers < -8.5)
    assert np.abs(np.diff(every.normalized[near])).max() > 0.2


# ---------------------------------------------------------------------------------- Fig. 4


def _bands(ax) -> list[PolyCollection]:
    return [c for c in ax.collections if isinstance(c, PolyCollection)]


@pytest.mark.slow
def test_fig4_labels_n_per_curve_and_bands_only_where_n_above_1(data):
    fig = fig4_forces(data)
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == len(data.surface_names) * len(data.subjects)
    for ax in panels:
        n_lines = len(ax.get_lines())
        ns = [t.get_text() for t in ax.texts if re.fullmatch(r"n = \d+", t.get_text())]
        assert len(ns) == n_lines == len(data.speeds)
        assert set(ns) == {"n = 2"}  # the synthetic study: 2 repetitions per speed
        assert len(_bands(ax)) == n_lines
    # keep one repetition: n = 1 everywhere and no SD band at all
    one = dataclasses.replace(data, trials=[t for t in data.trials if t.repetition == 1])
    fig = fig4_forces(one)
    for ax in (a for a in fig.axes if a.get_title()):
        assert {t.get_text() for t in ax.texts if t.get_text().startswith("n =")} == {"n = 1"}
        assert _bands(ax) == []


@pytest.mark.slow
def test_fig4_says_which_footing_it_shows(data):
    # the fixture has absolute forces
    assert "Footing: absolute" in fig4_forces(data)._suptitle.get_text()
    paper_only = dataclasses.replace(data, trials=[
        dataclasses.replace(t, forces=t.forces.drop(columns=["F_T_abs_N", "F_N_abs_N"]))
        for t in data.trials])
    assert "the paper's" in fig4_forces(paper_only)._suptitle.get_text()  # no absolute level
    trials = []
    for t in data.trials:
        f = t.forces.copy()
        f["F_T_abs_N"] = f["F_T_N"] + 0.15
        trials.append(dataclasses.replace(t, forces=f))
    absolute = dataclasses.replace(data, trials=trials)
    fig = fig4_forces(absolute)
    assert "Footing: absolute" in fig._suptitle.get_text()
    # on the absolute footing each trial's flat-ground level (0.15 N here) is taken off
    ax = next(a for a in fig.axes if a.get_title())
    y0 = ax.get_lines()[0].get_ydata()[0]
    assert abs(y0) < 10.0  # mN, not 150
    with pytest.raises(ValueError, match="footing must be"):
        fig4_forces(data, footing="relative")


# ---------------------------------------------------------------------------------- Fig. 6


@pytest.mark.slow
def test_fig6_names_its_footing_and_marks_region_events(data):
    fig = fig6_model(data)
    title = fig._suptitle.get_text()
    assert "Footing: absolute" in title and "steps where" in title  # the load-consistent default
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert all(re.search(r"\(n = \d+\)$", ax.get_title()) for ax in panels)
    # the synthetic regions split continuously at the gap (no finite jump in contact): no event
    assert all(region_events(t).size == 0 for t in data.trials)


def test_region_events_where_a_region_appears_with_a_finite_length():
    """As on the simulated step up at x = -9.02 mm: C_2 appears on the slope 0.87 mm long."""
    x = np.array([-9.2, -9.1, -9.0, -8.9, 5.0, 5.1])
    reg = np.full((6, 2, 2), np.nan)
    reg[:, 0] = np.column_stack([x - 5.0, x + 6.3])
    reg[2:4, 1] = [[0.35, 1.22], [0.14, 1.41]]  # appears at -9.0 ...
    reg[5, 1] = [11.5, 11.55]  # ... and a 0.05 mm speck at 5.1 is no step
    tr = TrialData(id="t", subject="1", surface="s", speed_mm_s=80.0, repetition=1,
                   frames=frames_table(0.001 * np.arange(6), x, reg), regions=reg, forces=pd.DataFrame())
    ev = region_events(tr)
    # appears between frames 1 and 2, vanishes (1.27 mm) between 3 and 4; the speck is no step
    np.testing.assert_allclose(ev, [-9.05, (-8.9 + 5.0) / 2])
