"""A real headless browser for tests and screenshots: Debian's Chromium driven by selenium.

``ensure_chromium`` finds ``chromium`` and ``chromedriver`` on PATH and, when they are missing and
the process runs as root with apt-get, installs the Debian packages ``chromium`` and
``chromium-driver``; otherwise it raises :class:`BrowserNotFoundError` with the command a user
has to run (tests skip with that reason). selenium's own driver download (selenium-manager) is
never used: the driver is the one Debian ships with the browser, so their versions match.
"""

from __future__ import annotations

import logging
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dempath.aptinstall import apt_install, apt_lock, can_install
from dempath.errors import DempathError

LOG = logging.getLogger(__name__)
APT_PACKAGES = ('chromium', 'chromium-driver')
BROWSERS = ('chromium', 'chromium-browser', 'google-chrome')
INSTALL_HINT = 'sudo apt-get install -y chromium chromium-driver'


class BrowserNotFoundError(DempathError):
    """No Chromium with its driver on this machine, and it cannot be installed here."""


@dataclass(frozen=True)
class Chromium:
    """Paths of the browser and of its WebDriver."""

    browser: str
    driver: str


def find_chromium() -> Chromium | None:
    """Chromium and chromedriver on PATH, or None."""
    browser = next((p for p in map(shutil.which, BROWSERS) if p), None)
    driver = shutil.which('chromedriver')
    return Chromium(browser, driver) if browser and driver else None


def ensure_chromium(install: bool = True, timeout_s: float = 900.0) -> Chromium:
    """Find Chromium and its driver, installing the Debian packages when allowed.

    Raises:
        BrowserNotFoundError: Missing and not installable here (names the command to run).
    """
    found = find_chromium()
    if found or not install:
        if found:
            return found
        msg = f'chromium: not installed; run {INSTALL_HINT!r}'
        raise BrowserNotFoundError(msg)
    if not can_install():
        msg = f'chromium: not installed and this process cannot install it; run {INSTALL_HINT!r}'
        raise BrowserNotFoundError(msg)
    with apt_lock():  # another process may be installing it right now: wait, look again
        found = find_chromium()
        failure = None if found else apt_install(APT_PACKAGES, timeout_s)
        if failure:
            msg = f'chromium: {failure}'
            raise BrowserNotFoundError(msg)
        found = found or find_chromium()
    if found is None:
        msg = f'chromium: installed {", ".join(APT_PACKAGES)} but chromedriver is not on PATH'
        raise BrowserNotFoundError(msg)
    return found


def headless_chromium(width: int = 1600, height: int = 900,
                      download_dir: Path | None = None) -> Any:
    """A selenium WebDriver of a headless Chromium window of ``width`` x ``height`` CSS px.

    Raises:
        BrowserNotFoundError: As :func:`ensure_chromium`.
    """
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium = ensure_chromium()
    options = webdriver.ChromeOptions()
    options.binary_location = chromium.browser
    for arg in ('--headless=new', '--no-sandbox', '--disable-dev-shm-usage', '--disable-gpu',
                f'--window-size={width},{height}', '--force-device-scale-factor=1',
                '--hide-scrollbars'):
        options.add_argument(arg)
    if download_dir is not None:
        options.add_experimental_option('prefs', {
            'download.default_directory': str(download_dir),
            'download.prompt_for_download': False})
    return webdriver.Chrome(options=options, service=Service(executable_path=chromium.driver))
