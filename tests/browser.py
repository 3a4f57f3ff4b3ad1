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
