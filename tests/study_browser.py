"""Debian's headless chromium through selenium, and a study served at its first trial, for the page's tests
(and for scripts/docs_studies.py, which photographs the page for docs/studies.md)."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


def chromium_available() -> bool:
    return Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()


def chromium(profile: Path, viewport: tuple[int, int] = (1100, 1000)):
    """A headless chromium whose page area (the viewport) is exactly ``viewport`` CSS pixels."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars",
                f"--user-data-dir={profile}", f"--window-size={viewport[0]},{viewport[1]}"):
        options.add_argument(arg)
    # An explicit driver path: selenium never looks for (or downloads) a browser or driver of its own.
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": viewport[0], "height": viewport[1], "deviceScaleFactor": 1, "mobile": False})
    return driver


@contextmanager
def served_study(study_path: Path, results: Path, participant: str = "P01", *, screen: str = "trial", played=True):
    """``study_path`` served for ``participant`` on memory actuators, at its first trial's instructions
    (``screen="instructions"``) or past them with every slot played (``played=True``): ``(session, server)``."""
    from hapticfx.study.player import StimulusPlayer
    from hapticfx.study.schedule import build_schedule
    from hapticfx.study.server import StudyServer
    from hapticfx.study.session import Session
    from hapticfx.study.spec import load_study

    study = load_study(study_path)
    with StimulusPlayer(study, build_schedule(study, participant), device="memory", realtime=False) as player:
        session = Session(study, participant, results, player, study_text=Path(study_path).read_bytes())
        try:
            first = session.schedule[session.position]
            if screen == "trial":
                session.proceed(first.index, "instructions")
                for slot in first.slots if played else []:
                    session.play(first.index, slot.name)
            with StudyServer(session) as server:
                yield session, server
        finally:
            session.close()


def wait_for_screen(driver, timeout: float = 10.0) -> str:
    """The screen the page shows once it has one (not loading, not busy)."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    WebDriverWait(driver, timeout).until(
        lambda d: d.find_element(By.ID, "app").get_attribute("data-screen") not in (None, "", "busy"))
    return driver.find_element(By.ID, "app").get_attribute("data-screen")
