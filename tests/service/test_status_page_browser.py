"""The status page in a real headless Chromium (Debian's chromium + chromium-driver, driven
by selenium): it loads, and while a simulated pass runs (the follower on the emu:// GS-232B
with a fast SimClock, in a thread, writing through BoardFeed) it updates in place; and the
docs' screenshot (``_station_demo.py``) is made. Every wait is a poll with a generous
deadline."""

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

    from tracker.api import Bench, SimClock, make_controller
    from tracker.service.web import StatusServer

    passes, k = demo.two_passes(demo.parse_at("2026-08-22T13:00Z"))
    pas = passes[k]
    # 20x: the pre-position and the pass's first minutes take a few real seconds
    clock = SimClock(pas.aos - timedelta(seconds=90), speed=20.0)
    board = demo.station_board(clock, passes)
    station = demo.DemoStation(board, passes)
    stop = threading.Event()
    failure: list[BaseException] = []

    with Bench(make_controller("gs232b", clock, rotator="G-5500")) as bench:
        follower = demo.follower(station, clock, bench, pas)

        def run() -> None:
            try:
                follower.run(passes=1, should_stop=stop.is_set)
            except BaseException as e:   # reported by the test, not lost in the thread
                failure.append(e)
            finally:
                follower.close()

        loop = threading.Thread(target=run, name="pass", daemon=True)
        with StatusServer(board, port=0) as server, headless_chromium(1100, 800) as browser:
            loop.start()
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
                assert _js(browser, "return document.querySelectorAll("
                                    "'#timeline-bars .bar').length") >= 3
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
