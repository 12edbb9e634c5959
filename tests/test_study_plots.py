"""The study figures, measured as matplotlib lays them out: tick labels that do not run into each other, titles
that say a name once and say "simulated" when simulated participants answered, confusion matrices on one colour
scale with a colour bar, and the chance level where guessing has one.

The figures are drawn from the paper's two studies simulated in full (the results docs/studies.md shows).
"""

from __future__ import annotations

import dataclasses
import re
from itertools import combinations

import pytest

pytest.importorskip("pandas")
pytestmark = pytest.mark.slow  # the paper's two studies simulated once (the fixture test_docs_figures.py shares)

from hapticfx.study import plots  # noqa: E402


def _every_figure(analyses):
    for key, a in analyses.items():
        for name, fig in plots.figures(a).items():
            yield f"{key}/{name}", fig


def _texts(fig) -> list[str]:
    titles = [ax.get_title() for ax in fig.axes] + [fig._suptitle.get_text() if fig._suptitle else ""]
    return [t for t in titles if t]


def test_no_two_tick_labels_overlap(paper_analyses):
    checked = 0
    for name, fig in _every_figure(paper_analyses):
        renderer = fig.canvas.get_renderer()
        fig.canvas.draw()
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in axis.get_ticklabels()
                         if t.get_visible() and t.get_text()]
                for (a, box_a), (b, box_b) in combinations(boxes, 2):
                    assert not box_a.overlaps(box_b), f"{name}: tick labels {a!r} and {b!r} overlap"
                checked += len(boxes)
    assert checked > 60  # the study 1 means plot alone labels 16 conditions


def test_titles_name_things_once_and_say_simulated(paper_analyses):
    for name, fig in _every_figure(paper_analyses):
        texts = _texts(fig)
        assert any("simulated participants" in t for t in texts), (name, texts)
        for t in texts:
            assert not re.search(r"(?<![\w-])([\w-]+): \1(?![\w-])", t), f"{name}: a repeated title {t!r}"
    people = dataclasses.replace(paper_analyses["study1"], simulated=[])  # the same answers, said to be people's
    for name, fig in plots.figures(people).items():
        assert not [t for t in _texts(fig) if "simulated" in t] and any("12 participants" in t for t in _texts(fig))


def test_confusion_matrices_share_one_colour_scale_with_a_colour_bar_and_name_chance(paper_analyses):
    a = paper_analyses["study2"]
    fig = plots.confusion_figure(a.matching, a.who)
    panels = [ax for ax in fig.axes if ax.images]
    bars = [ax for ax in fig.axes if not ax.images]
    assert len(panels) == len(a.matching) == 5
    assert len(bars) == 1 and "%" in bars[0].get_ylabel()  # one colour bar for all panels
    assert {ax.images[0].get_clim() for ax in panels} == {(0.0, 100.0)}
    assert all("(chance 25%)" in ax.get_title() for ax in panels)


def test_recognition_rates_draw_the_chance_level(paper_analyses):
    a = paper_analyses["study2"]
    assert {m.chance_pct for m in a.matching} == {25.0}  # four comparisons per trial
    fig = plots.recognition_figure(a.matching, a.who)
    (ax,) = fig.axes
    flat = [line for line in ax.get_lines() if len(set(line.get_ydata())) == 1 and line.get_label().startswith("chance")]
    assert [tuple(line.get_ydata()) for line in flat] == [(25.0, 25.0)]
