"""The status page in a real headless Chromium (Debian's chromium + chromium-driver, driven
by selenium): it loads, and while a real station service runs a simulated pass (the ISS on
the in-process GS-232B emulator, virtual time held to 20x real time, in a thread) it updates
in place; and the docs' screenshot (``_station_demo.py``) is made. Every wait is a poll with
a generous deadline."""

from __future__ import annotations

import os
import threading
from datetime import timedelta

import _station_demo as demo
import pytest
from _browser import chromium_missing, headless_chromium

MISSING = chromium_missing()
if MISSING is not None:
    # CI's .ci/run installs the browser: missing there is a failure, not a skip
    if os.environ.get("CI", "").lower() == "true":
        raise RuntimeError(f"no headless browser but CI=true: {MISSING}")
    pytest.skip(f"no headless browser: {MISSING}", allow_module_level=True)

WAIT_S = 90.0          # a loaded machine is slow, never wrong
PNG = b"\x89PNG\r\n\x1a\n"


def _js(browser, script: str):
    return browser.execute_script(script)


def test_the_page_follows_a_simulated_pass():
    from selenium.webdriver.support.ui import WebDriverWait

    from tracker.api import PacedClock
    from tracker.service.web import StatusServer

    _before, pas = demo.high_pass(demo.parse_at("2026-08-22T13:00Z"))
    # 20x from shortly before the station takes the pass: the pre-position and the pass's
    # first minutes take a few real seconds
    clock = PacedClock(pas.aos - timedelta(seconds=300), speed=20.0)
    service, bench = demo.station(clock)
    board = service.board
    stop = threading.Event()
    failure: list[BaseException] = []

    with bench:
        with StatusServer(board, port=0) as server, headless_chromium(1100, 800) as browser:
            loop = demo.run_in_thread(service, stop, failure)
            try:
                browser.get(server.url)
                wait = WebDriverWait(browser, WAIT_S, poll_frequency=0.2)
                assert "SIMULATION" in browser.find_element("id", "sim-banner").text
                wait.until(lambda d: _js(d, "return document.getElementById('ant-az')"
                                            ".textContent") != "-")
                az1 = _js(browser, "return document.getElementById('ant-az').textContent")
                mark1 = _js(browser, "return document.getElementById('sky-antenna')"
                                     ".getAttribute('transform')")
                # the antenna turns (pre-position, then the pass): the page follows
                wait.until(lambda d: _js(d, "return document.getElementById('ant-az')"
                                            ".textContent") != az1)
                wait.until(lambda d: _js(d, "return document.getElementById('sky-antenna')"
                                            ".getAttribute('transform')") != mark1)
                wait.until(lambda d: _js(d, "return document.getElementById('sky-path')"
                                            ".getAttribute('points')").count(",") > 10)
                wait.until(lambda d: _js(d, "return document.getElementById('state')"
                                            ".textContent") in ("prepositioning", "tracking"))
                assert _js(browser, "return document.getElementById('sky-antenna')"
                                    ".hasAttribute('hidden')") is False
                assert "ISS (ZARYA)" in browser.find_element("id", "current-pass").text
                # the schedule is polled every 10 s
                wait.until(lambda d: _js(d, "return document.querySelectorAll("
                                            "'#timeline-bars .bar').length") >= 3)
                shot = browser.get_screenshot_as_png()
            finally:
                stop.set()
                loop.join(WAIT_S)
    assert not failure, failure
    assert not loop.is_alive()
    assert shot.startswith(PNG) and len(shot) > 30_000
    assert int.from_bytes(shot[16:20], "big") == 1100      # IHDR width: the viewport


def test_the_docs_screenshot_is_made(tmp_path):
    out = tmp_path / "page.png"
    assert demo.main(["--out", str(out)]) == 0
    data = out.read_bytes()
    assert data.startswith(PNG) and len(data) > 30_000
    assert (int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")) == \
        (1100, 800)
