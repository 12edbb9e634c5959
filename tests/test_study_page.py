"""The participant's page in a real browser (Debian's headless chromium through selenium), and its HTTP API.

A scripted participant completes a short study by clicking; what the results
file holds must equal what was clicked, a reload must keep a draft answer, and
nothing may be asked twice. Stimuli play on memory actuators (no hardware here).
"""

from __future__ import annotations

import json
import urllib.error
import urllib.request
from pathlib import Path

import pytest


CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


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


def _browser(profile: Path):
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    if not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()):
        pytest.skip("needs Debian's chromium and chromium-driver (scripts/install.sh --test installs them)")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
                "--window-size=1100,1000"):
        options.add_argument(arg)
    # An explicit driver path: selenium never looks for (or downloads) a browser or driver of its own.
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def test_a_scripted_participant_completes_the_study_in_chromium(served, tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    session, server, player = served
    driver = _browser(tmp_path / "chromium-profile")  # pytest's tmp dir: Chromium's helpers may still write after quit
    clicked, plays, reloaded = [], 0, False
    try:
        driver.get(server.url)
        wait = WebDriverWait(driver, 10)

        def screen():
            wait.until(lambda d: d.find_element(By.ID, "app").get_attribute("data-screen") not in (None, "", "busy"))
            return driver.find_element(By.ID, "app").get_attribute("data-screen")

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
