#!/usr/bin/env python3
"""Regenerate the simulated results that docs/studies.md shows, from what the study commands compute now.

    python scripts/docs_studies.py            # rewrite the report excerpts and the figures in docs/
    python scripts/docs_studies.py --page     # ... and photograph the participant's page (headless chromium)
    python scripts/docs_studies.py --check    # exit 1, saying what differs, if the page is out of date

Each paper study is run as `hapticfx study run STUDY --simulate --device memory` runs it (the same
function, every participant of the study's `simulate` section) and analysed as `hapticfx study analyze`
does. The excerpts sit between `<!-- generated: NAME -->` and `<!-- end generated -->` in docs/studies.md;
each figure carries the SHA-256 of the numbers it draws in its PNG metadata, so a check can tell a figure
drawn from other numbers without comparing pixels. tests/test_docs_figures.py runs the check.
"""

from __future__ import annotations

import argparse
import hashlib
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "studies.md"
IMAGES = ROOT / "docs" / "images" / "studies"
STUDIES = {"study1": ROOT / "studies" / "paper_study1.yaml", "study2": ROOT / "studies" / "paper_study2.yaml"}
DIGEST_KEY = "hapticfx-data-sha256"
BLOCK = re.compile(r"<!-- generated: (?P<name>[\w-]+) -->\n```text\n(?P<body>.*?)```\n<!-- end generated -->", re.S)


def simulate(study: Path, results: Path):
    """Simulate every participant of ``study`` into ``results`` on memory actuators and analyse the folder."""
    from hapticfx.study.analysis import analyse
    from hapticfx.study.commands import run_one
    from hapticfx.study.results import load_folder
    from hapticfx.study.spec import load_study

    spec = load_study(study)
    for p in range(1, spec.simulate.participants + 1):
        run_one(study, f"P{p:02d}", results, device="memory", port=0, simulate=True, pace_s=0.0, echo=lambda *_: None)
    return analyse(load_folder(results))


def analyses(work: Path) -> dict:
    """Both paper studies, simulated and analysed: {"study1": Analysis, "study2": Analysis}."""
    return {key: simulate(path, work / key) for key, path in STUDIES.items()}


def _rating(a, task: str, question: str):
    return next(r for r in a.ratings if r.task == task and r.question == question)


def _section(report: str, head: str) -> str:
    """The report's paragraph that starts with ``head``."""
    return next(p for p in report.split("\n\n") if p.startswith(head)).rstrip("\n") + "\n"


def blocks(done: dict) -> dict[str, str]:
    """The report excerpts docs/studies.md shows, by block name."""
    from hapticfx.study.analysis import report

    one, two = report(done["study1"]), report(done["study2"])
    matching = "".join(line + "\n" for line in two.splitlines() if re.match(r"[\w-]+: [\d.]+% correct", line))
    return {"study1-report": one.splitlines()[0] + "\n\n" + _section(one, "realism / realism:"),
            "study2-report": two.splitlines()[0] + "\n\n" + _section(two, "similarity / similarity:") + "\n" + matching}


def _csv(frame) -> str:
    return frame.to_csv(index=True, float_format="%.9g")


def figures(done: dict) -> dict[str, tuple]:
    """The figures docs/studies.md shows: file name -> (a function drawing it, the numbers it draws as text)."""
    from hapticfx.study import plots

    s1, s2 = done["study1"], done["study2"]
    realism, similarity = _rating(s1, "realism", "realism"), _rating(s2, "similarity", "similarity")

    def bars(r, who):
        return _csv(r.means) + repr(sorted(r.references.items())) + who

    return {
        "study1-realism-means.png": (lambda: plots.rating_bars_figure(realism, s1.who), bars(realism, s1.who)),
        "study1-realism-boxes.png": (lambda: plots.rating_boxes_figure(realism, s1.who), _csv(realism.subject_means) + s1.who),
        "study2-confusion.png": (lambda: plots.confusion_figure(s2.matching, s2.who),
                                 "".join(m.task + _csv(m.confusion) + f"{m.chance_pct:.9g}" for m in s2.matching) + s2.who),
        "study2-recognition.png": (lambda: plots.recognition_figure(s2.matching, s2.who),
                                   repr([(m.task, m.per_level_pct, m.chance_pct) for m in s2.matching]) + s2.who),
        "study2-similarity.png": (lambda: plots.rating_bars_figure(similarity, s2.who), bars(similarity, s2.who)),
    }


def digest(numbers: str) -> str:
    return hashlib.sha256(numbers.encode()).hexdigest()


def documented_blocks(text: str) -> dict[str, str]:
    return {m["name"]: m["body"] for m in BLOCK.finditer(text)}


def documented_digest(png: Path) -> str | None:
    from PIL import Image

    with Image.open(png) as image:
        return image.text.get(DIGEST_KEY)


def differences(done: dict) -> list[str]:
    """What docs/studies.md shows that the commands no longer compute (empty when it is up to date)."""
    out = []
    shown = documented_blocks(DOC.read_text())
    for name, body in blocks(done).items():
        if shown.get(name) != body:
            out.append(f"docs/studies.md block {name!r} differs from the report")
    for name, (_, numbers) in figures(done).items():
        png = IMAGES / name
        if not png.exists() or documented_digest(png) != digest(numbers):
            out.append(f"docs/images/studies/{name} was not drawn from the numbers computed now")
    return out


def write(done: dict) -> list[Path]:
    """Rewrite the blocks of docs/studies.md and its figures."""
    from hapticfx.study.plots import save

    text = DOC.read_text()
    new = blocks(done)
    missing = set(new) - set(documented_blocks(text))
    if missing:
        raise SystemExit(f"docs/studies.md has no <!-- generated: NAME --> block for {', '.join(sorted(missing))}")
    DOC.write_text(BLOCK.sub(lambda m: f"<!-- generated: {m['name']} -->\n```text\n{new.get(m['name'], m['body'])}```\n"
                                       "<!-- end generated -->", text))
    written = [DOC]
    for name, (draw, numbers) in figures(done).items():
        written.append(save(draw(), IMAGES / name, metadata={DIGEST_KEY: digest(numbers)}))
    return written


def photograph_page(work: Path) -> list[Path]:
    """The participant's page in headless chromium, 1280x660 (a 1280x800 window): instructions, a rating trial
    before the sliders are touched, a matching trial with a chosen comparison."""
    sys.path.insert(0, str(ROOT / "tests"))
    from selenium.webdriver.common.by import By
    from study_browser import chromium, served_study, wait_for_screen

    driver = chromium(work / "chromium-profile", (1280, 660))
    shots = []
    try:
        for name, study, screen, choose in (("page-instructions.png", "study1", "instructions", None),
                                            ("page-rating.png", "study1", "trial", None),
                                            ("page-matching.png", "study2", "trial", "choose-B")):
            with served_study(STUDIES[study], work / f"page-{name}", screen=screen) as (_, server):
                driver.get(server.url)
                wait_for_screen(driver)
                if choose:
                    driver.find_element(By.ID, choose).click()
                    wait_for_screen(driver)
                IMAGES.joinpath(name).write_bytes(driver.get_screenshot_as_png())
                shots.append(IMAGES / name)
    finally:
        driver.quit()
    return shots


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only say whether docs/studies.md is up to date (exit 1 if not)")
    parser.add_argument("--page", action="store_true", help="also photograph the participant's page (needs chromium)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="hapticfx-docs-studies-") as tmp:
        print("simulating the paper's two studies (about 20 s)", file=sys.stderr)
        done = analyses(Path(tmp))
        if args.check:
            diff = differences(done)
            print("\n".join(diff) or "docs/studies.md is up to date")
            return 1 if diff else 0
        paths = write(done) + (photograph_page(Path(tmp)) if args.page else [])
    print("wrote " + ", ".join(str(p.relative_to(ROOT)) for p in paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
