"""One progress style: a line redrawn in place on a terminal, a few plain lines in a log."""

from __future__ import annotations

import io

from hapticfx.progress import Progress


class Tty(io.StringIO):
    def isatty(self):
        return True


def test_in_a_log_it_writes_the_start_then_at_most_every_few_seconds_and_the_end():
    out = io.StringIO()
    with Progress(1000, "fold", unit="fits", stream=out, every_s=3600) as p:
        for _ in range(1000):
            p.update(note="rmse 0.1")
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("fold: 0/1000 fits") and lines[-1].startswith("fold: 1000/1000 fits")
    assert len(lines) == 2 and "rmse 0.1" in lines[-1]


def test_on_a_terminal_it_redraws_one_line_and_says_status_above_it():
    out = Tty()
    with Progress(4, "train", unit="epochs", stream=out) as p:
        p.update()
        p.say("checkpoint written")
        p.update(3)
    text = out.getvalue()
    assert text.count("\n") == 2 and "checkpoint written\n" in text
    assert text.rstrip("\n").split("\r")[-1].startswith("train: [####################] 4/4 epochs")
