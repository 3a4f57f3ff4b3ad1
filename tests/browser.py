"""A headless Chromium for the page tests (Debian's chromium and chromium-driver, by selenium).

``.ci/run`` installs both; a machine without a ``chromium`` binary skips the browser tests with
that reason.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
NO_BROWSER = ("no chromium binary on this machine (apt-get install -y chromium "
              "chromium-driver; .ci/run installs them)")
needs_browser = pytest.mark.skipif(CHROMIUM is None, reason=NO_BROWSER)


@contextmanager
def chromium(width: int = 1300, height: int = 900) -> Iterator[Any]:
    """A headless Chromium driven by selenium, its console log kept."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--window-size={width},{height}"):
        options.add_argument(arg)
    options.binary_location = CHROMIUM
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    service = Service(CHROMEDRIVER) if CHROMEDRIVER else Service()
    driver = webdriver.Chrome(service=service, options=options)
    try:
        yield driver
    finally:
        driver.quit()


def open_page(driver: Any, path: Path, timeout: float = 60.0) -> float:
    """Open a page and wait for the solution page to be ready; give its load time (ms).

    The time is the page's own: from navigation start to the end of the page's start-up
    (``performance.now()`` when ``window.tmaPage`` is ready).
    """
    from selenium.webdriver.support.ui import WebDriverWait

    driver.get(Path(path).resolve().as_uri())
    WebDriverWait(driver, timeout).until(
        lambda d: d.execute_script("return !!(window.tmaPage && window.tmaPage.ready)"))
    return float(driver.execute_script("return window.tmaPage.readyAt"))


def console_errors(driver: Any) -> list[dict[str, Any]]:
    """The browser console's errors (and severe messages) since the last call."""
    return [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]


#: The viewport position of a point of the page's map (Bokeh's view of the figure ``map``).
SCREEN_OF = """
    const fig = Bokeh.documents[0].get_model_by_name('map');
    const find = (views) => {
      for (const w of views) {
        if (w.model === fig) return w;
        const c = find(w.child_views || []);
        if (c) return c;
      }
      return null;
    };
    const v = find([...Bokeh.index.roots]);
    const r = v.el.getBoundingClientRect();
    return [r.left + v.frame.x_scale.compute(arguments[0]),
            r.top + v.frame.y_scale.compute(arguments[1])];"""


def screen_of(driver: Any, x: float, y: float) -> tuple[float, float]:
    """The browser's viewport coordinates of a point of the map (lon, lat or km)."""
    sx, sy = driver.execute_script(SCREEN_OF, x, y)
    return float(sx), float(sy)


def settled(driver: Any) -> None:
    """Wait until the page has made the update a drag asked for (at the next frame)."""
    driver.execute_async_script("""
        const done = arguments[arguments.length - 1];
        (function wait() {
          window.tmaPage.pending() ? requestAnimationFrame(wait) : done();
        })();""")


def painted(driver: Any) -> float:
    """Wait for the page's first frame after it was ready; give its time (ms since navigation)."""
    driver.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "(function wait() { window.tmaPage.paintedAt ? done() : requestAnimationFrame(wait); })()")
    return float(driver.execute_script("return window.tmaPage.paintedAt"))


def drag_handle(driver: Any, moves: int = 20, step: tuple[float, float] = (4.0, 3.0)
                ) -> list[dict[str, float]]:
    """Drag the solution's position handle by the mouse; give the page's timings of the drag.

    Each timing is one update of the dots: ``painted_ms`` from the mouse event to the end of
    the repaint of every plot the update changed, ``compute_ms`` the update's own work.
    """
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    hx, hy = driver.execute_script(
        "const d = Bokeh.documents[0].get_model_by_name('handles').data; return [d.x[0], d.y[0]]")
    x0, y0 = screen_of(driver, hx, hy)
    driver.execute_script("window.tmaPage.timings.length = 0")
    ab = ActionBuilder(driver, duration=30)
    ab.pointer_action.move_to_location(round(x0), round(y0))
    ab.pointer_action.pointer_down()
    for k in range(1, moves + 1):
        ab.pointer_action.move_to_location(round(x0 + step[0] * k), round(y0 + step[1] * k))
    ab.pointer_action.pointer_up()
    ab.perform()
    settled(driver)
    driver.execute_async_script("requestAnimationFrame(() => requestAnimationFrame("
                                "arguments[arguments.length - 1]))")
    return list(driver.execute_script("return window.tmaPage.timings"))
