"""Opening a page in a real headless browser (Debian's Chromium) for the tests: the DOM after
the load event, every console message, and a screenshot; and whether a screenshot is blank."""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def _run(page: Path, *flags: str) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory() as profile:
        # --no-sandbox: CI containers run as root, where Chromium's sandbox refuses to start.
        return subprocess.run([chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                               "--no-first-run", f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                               *flags, page.resolve().as_uri()],
                              capture_output=True, text=True, timeout=120)


def open_page(page: Path, screenshot: Path, width: int = 1280, height: int = 2400) -> tuple[str, list[str]]:
    """(the DOM after load, console messages of both loads); writes the screenshot PNG."""
    dom = _run(page, "--dump-dom")
    shot = _run(page, f"--window-size={width},{height}", f"--screenshot={screenshot}")
    if dom.returncode != 0 or shot.returncode != 0 or not screenshot.exists():
        raise RuntimeError(f"chromium failed: {dom.stderr[-500:]}{shot.stderr[-500:]}")
    console = [line for line in (dom.stderr + shot.stderr).splitlines() if ":CONSOLE" in line]
    return dom.stdout, console


def ink(screenshot: Path) -> tuple[float, float]:
    """(share of pixels that are not near-white, grey-level standard deviation)."""
    from PIL import Image

    grey = np.asarray(Image.open(screenshot).convert("L"), dtype=float)
    return float((grey < 235).mean()), float(grey.std())
