"""The participant's page in a real browser (Debian's headless chromium through selenium), and its HTTP API.

A scripted participant completes a short study by clicking; what the results
file holds must equal what was clicked, a reload must keep a draft answer, and
nothing may be asked twice. Stimuli play on memory actuators (no hardware here).
"""

from __future__ import annotations

import json
import re
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from study_browser import chromium, chromium_available, served_study, wait_for_screen


def _post(server, path, body, token=None):
    req = urllib.request.Request(server.url.rstrip("/") + path, data=json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json", "X-Study-Token": token or server.token})
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def test_api_refuses_what_does_not_belong_and_answers_once(served):
    session, server, _ = served
    assert _post(server, "/api/proceed", {"trial": 0, "screen": "instructions"}, token="forged")[0] == 403
    assert _post(server, "/api/answer", {"trial": 3, "response": {}})[0] == 409
    status, state = _post(server, "/api/proceed", {"trial": 0, "screen": "instructions"})
    assert status == 200 and state["screen"] == "trial"
    assert not [name for name in session.study.stimuli if name in json.dumps(state)]  # the page cannot tell conditions
    assert _post(server, "/api/answer", {"trial": 0, "response": {"ratings": {"realism": 50}}}) == \
        (409, {"error": "play stimulus before answering"})
    assert _post(server, "/api/play", {"trial": 0, "slot": "stimulus"})[0] == 200
    assert _post(server, "/api/play", {"trial": 0, "slot": "stimulus"})[1]["error"].startswith("this task plays each impact once")
    assert _post(server, "/api/answer", {"trial": 0, "response": {"ratings": {"realism": 101}}})[0] == 409
    ok = _post(server, "/api/answer", {"trial": 0, "response": {"ratings": {"realism": 42.5}}})
    again = _post(server, "/api/answer", {"trial": 0, "response": {"ratings": {"realism": 99}}})
    assert ok[0] == again[0] == 200 and again[1]["duplicate"] is True
    answers = [json.loads(line) for line in session.log.path.read_text().splitlines() if '"answer"' in line]
    assert [a["response"] for a in answers] == [{"ratings": {"realism": 42.5}}]


def _browser(profile: Path, viewport=(1100, 1000)):
    pytest.importorskip("selenium.webdriver")
    if not chromium_available():
        pytest.skip("needs Debian's chromium and chromium-driver (scripts/install.sh --test installs them)")
    return chromium(profile, viewport)


def test_a_scripted_participant_completes_the_study_in_chromium(served, tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    session, server, player = served
    driver = _browser(tmp_path / "chromium-profile")  # pytest's tmp dir: Chromium's helpers may still write after quit
    clicked, plays, reloaded = [], 0, False
    try:
        driver.get(server.url)

        def screen():
            return wait_for_screen(driver)

        def click(element_id):
            driver.find_element(By.ID, element_id).click()
            return screen()

        while (now := screen()) != "done":
            if now in ("instructions", "break"):
                click("proceed")
                continue
            for button in [b.get_attribute("id") for b in driver.find_elements(By.CSS_SELECTOR, "button.play")]:
                click(button)
                plays += 1
            choose = driver.find_elements(By.CSS_SELECTOR, "button.choose")
            if choose:
                pick = choose[len(clicked) % len(choose)].get_attribute("id")
                click(pick)
                clicked.append({"choice": pick.removeprefix("choose-")})
            else:
                ratings = {}
                for k, slider in enumerate(driver.find_elements(By.CSS_SELECTOR, "input[type=range]")):
                    width = slider.size["width"]
                    offset = int(width * (0.15 + 0.7 * ((len(clicked) * 37 + k * 11) % 100) / 100)) - width // 2
                    ActionChains(driver).move_to_element_with_offset(slider, offset, 0).click().perform()
                    ratings[slider.get_attribute("id").removeprefix("rating-")] = float(slider.get_property("value"))
                if not reloaded:  # a reload before "Next" keeps the answer being given
                    driver.refresh()
                    screen()
                    reloaded = True
                    for qid, value in ratings.items():
                        assert float(driver.find_element(By.ID, f"rating-{qid}").get_property("value")) == value
                clicked.append({"ratings": ratings})
            assert driver.find_element(By.ID, "submit").is_enabled()
            click("submit")
        assert "Thank you" in driver.find_element(By.ID, "done").text
    finally:
        driver.quit()
    records = [json.loads(line) for line in session.log.path.read_text().splitlines()]
    answers = [r for r in records if r["type"] == "answer"]
    assert [a["response"] for a in answers] == clicked
    assert [a["trial"] for a in answers] == list(range(len(session.schedule)))
    assert records[-1]["type"] == "done"
    assert len(player.engine.played()) == sum(len(s.velocities) for t in session.schedule for s in t.slots)
    assert plays == sum(len(t.slots) for t in session.schedule)
    assert len({r for a in clicked if "ratings" in a for r in a["ratings"].values()}) > 3  # the sliders really moved


# --- how the page looks: a 1280x800 window, measured in the browser ------------------------------------------------

STUDIES = Path(__file__).resolve().parents[1] / "studies"
# A 1280x800 window leaves about 1280x660 to the page once a title bar, the browser's tab strip, address bar
# and bookmarks bar are drawn (about 140 px in Chromium and Firefox).
WINDOW_PAGE_AREA = (1280, 660)


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    driver = _browser(tmp_path_factory.mktemp("chromium-profile"), WINDOW_PAGE_AREA)
    yield driver
    driver.quit()


def _pixels(element):
    """The element as the browser drew it: an (height, width, 3) array of 0-255 values."""
    import io

    import numpy as np
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(element.screenshot_as_png)).convert("RGB")).astype(int)


def test_an_untouched_slider_draws_no_fill_and_no_thumb_until_first_input(browser, tmp_path):
    """docs/studies.md promises no default position to anchor on: before the first input every column of the
    slider's track looks the same (no thumb, no fill up to the midpoint), after it the thumb shows, still no fill."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    with served_study(STUDIES / "paper_study1.yaml", tmp_path / "results") as (_, server):
        browser.get(server.url)
        assert wait_for_screen(browser) == "trial"
        sliders = browser.find_elements(By.CSS_SELECTOR, "input[type=range]")
        assert len(sliders) == 2 and all(s.is_enabled() for s in sliders)
        for slider in sliders:
            px = _pixels(slider)
            w = px.shape[1]
            inner = px[:, 20:w - 20]  # past the track's rounded ends
            assert (inner != inner[:, [w // 2 - 20]]).sum() == 0, "an untouched slider marks a position"
            assert slider.get_attribute("aria-valuetext") == "no answer yet"
        first = sliders[0]
        ActionChains(browser).move_to_element_with_offset(first, int(-0.2 * first.size["width"]), 0).click().perform()
        px = _pixels(first)
        w = px.shape[1]
        thumb, left, right = int(0.3 * w), int(0.1 * w), int(0.8 * w)
        assert (px[:, thumb - 5:thumb + 5] != px[:, [right]]).any(), "the thumb does not show after the first input"
        assert (px[:, left] == px[:, right]).all(), "the track is filled up to the thumb: the fill is an anchor too"
        assert first.get_attribute("aria-valuetext") is None
        assert 25 < float(first.get_property("value")) < 35


@pytest.mark.parametrize("study", ["paper_study1.yaml", "paper_study2.yaml"])
def test_next_is_visible_without_scrolling_in_a_1280x800_window(browser, tmp_path, study):
    """The tallest trials: study 1 rates two questions on a practice trial, study 2 matches a target among four."""
    with served_study(STUDIES / study, tmp_path / "results") as (_, server):
        browser.get(server.url)
        assert wait_for_screen(browser) == "trial"
        box = browser.execute_script("const r = document.getElementById('submit').getBoundingClientRect();"
                                     "return [r.top, r.bottom, innerHeight, scrollY];")
    top, bottom, height, scrolled = box
    assert scrolled == 0 and 0 < top and bottom <= height, f"Next spans {top:.0f}-{bottom:.0f} px of a {height} px page"


def _luminance(css_colour: str) -> float:
    """WCAG relative luminance of a computed ``rgb(...)``/``rgba(...)`` colour."""
    r, g, b = (float(v) / 255 for v in re.findall(r"[\d.]+", css_colour)[:3])
    lin = [c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in (r, g, b)]
    return 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]


def test_a_chosen_comparison_is_marked_beyond_colour(browser, tmp_path):
    """Seen in greyscale or by a screen reader, the chosen comparison stands out: pressed, a check mark and
    "Chosen", a dark frame whose luminance contrasts at least 3:1 with the others' frames."""
    from selenium.webdriver.common.by import By

    with served_study(STUDIES / "paper_study2.yaml", tmp_path / "results") as (_, server):
        browser.get(server.url)
        assert wait_for_screen(browser) == "trial"
        browser.find_element(By.ID, "choose-B").click()
        wait_for_screen(browser)
        pressed = {b.get_attribute("id"): b.get_attribute("aria-pressed") for b in browser.find_elements(By.CSS_SELECTOR, "button.choose")}
        assert pressed == {"choose-A": "false", "choose-B": "true", "choose-C": "false", "choose-D": "false"}
        assert "Chosen" in browser.find_element(By.ID, "choose-B").text
        assert "Chosen" not in browser.find_element(By.ID, "choose-A").text
        style = browser.execute_script(
            "return [...document.querySelectorAll('.slot')].map(s => { const c = getComputedStyle(s);"
            " return [s.textContent, c.borderTopColor, c.borderTopWidth, c.outlineStyle, c.outlineWidth]; });")
    chosen = [s for s in style if "Impact B" in s[0]]
    others = [s for s in style if "Impact B" not in s[0]]
    assert len(chosen) == 1 and len(others) == 4 and "\u2713" in chosen[0][0]
    assert chosen[0][3] != "none" and float(chosen[0][4].removesuffix("px")) >= 2
    for other in others:
        assert "\u2713" not in other[0] and other[3] == "none"
        light, dark = sorted((_luminance(other[1]), _luminance(chosen[0][1])), reverse=True)
        assert (light + 0.05) / (dark + 0.05) >= 3.0, (other[1], chosen[0][1])


def test_the_served_stylesheet_holds_the_rules_the_browser_tests_measure(served):
    """Without chromium the tests above skip; this reads the served CSS instead (a weaker check: the rules exist,
    not what a browser draws with them)."""
    _, server, _ = served
    with urllib.request.urlopen(server.url.rstrip("/") + "/style.css", timeout=10) as r:
        css = re.sub(r"\s+", " ", r.read().decode())
    assert re.search(r"input\[type=range\] \{[^}]*appearance: none", css)  # no native fill of the track
    assert "::-moz-range-progress { background: transparent; }" in css
    for engine in ("webkit-slider", "moz-range"):
        assert f"input[type=range].untouched::-{engine}-thumb {{ visibility: hidden; }}" in css
    assert re.search(r"\.slot\.chosen \{[^}]*outline: 3px solid", css)
