"""`mpmpp report MODEL DATA -o report.html`: one self-contained page, opened in a real
headless browser (Chromium): it loads with no console message, every embedded figure
decodes, nothing is fetched from a network, and the screenshot is not blank."""
import os
import re

import pytest

from browser import chromium, ink, open_page
from cli_run import run_cli

HERE = os.path.dirname(os.path.abspath(__file__))
STREAM = os.path.join(HERE, "..", "data", "stream")
MODEL, DATA = os.path.join(STREAM, "model.json"), os.path.join(STREAM, "data.csv")
needs_browser = pytest.mark.skipif(chromium() is None, reason="Chromium is not installed (scripts/system-deps.sh)")


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "report.html"
    code, out, err = run_cli("report", MODEL, DATA, "-o", path, "--train-end", 10800, "--config", "paper_siso")
    assert code == 0, err
    return path


def test_the_page_is_self_contained_with_every_section(page):
    text = page.read_text(encoding="utf-8")
    for heading in ("Data", "Compare", "Diagnose", "Update", "Detect"):
        assert re.search(rf"<h2 id=\"\w+\">{heading}", text), heading
    assert "Not available" not in text  # every section computed on this record
    # Nothing outside the page: every src/href is embedded data or an in-page anchor.
    refs = re.findall(r"(?:src|href)=\"([^\"]*)\"", text)
    assert refs and all(r.startswith(("data:", "#")) for r in refs), [r[:40] for r in refs if not r.startswith("d")]
    figures = re.findall(r"src=\"data:image/png;base64,", text)
    assert len(figures) >= 7  # profiles, compare x2, before/after, error fall, timeline, detection x2
    # The alarms detect raised on this record are listed with their times.
    assert "model-plant mismatch" in text and "disturbance change" in text
    # the disturbance alarm has an MPM alarm on the same output: no pointer to a hidden process change
    assert "has no model-plant mismatch alarm beside it" not in text


def test_an_existing_page_is_not_overwritten(page):
    before = page.read_bytes()
    code, _, err = run_cli("report", MODEL, DATA, "-o", page)
    assert code == 2 and "--force" in err and page.read_bytes() == before


@needs_browser
def test_the_page_opens_in_a_headless_browser(page, tmp_path):
    shot = tmp_path / "report.png"
    dom, console = open_page(page, shot)
    assert console == [], console
    n_figures = len(re.findall(r"<img ", page.read_text(encoding="utf-8")))
    assert f'data-figures="ok {n_figures}"' in dom  # every figure decoded (set by the page on load)
    covered, spread = ink(shot)
    assert covered > 0.05 and spread > 20, (covered, spread)


@needs_browser
def test_the_browser_checks_catch_a_broken_page(tmp_path):
    """The same checks on a page with a corrupt figure and a script error all fail."""
    from mpmpp.report import _SCRIPT

    bad = tmp_path / "bad.html"
    bad.write_text(f"<!DOCTYPE html><html><head><script>{_SCRIPT}</script></head><body>"
                   "<img src=\"data:image/png;base64,AAAA\"><script>notDefined();</script></body></html>")
    dom, console = open_page(bad, tmp_path / "bad.png", height=600)
    assert any("notDefined" in line for line in console)
    assert 'data-figures="broken 1"' in dom
    covered, spread = ink(tmp_path / "bad.png")
    assert not (covered > 0.05 and spread > 20)


def test_figures_draw_on_the_data_s_own_clock(tmp_path):
    """Detection figures and the alarm timeline with timestamps (an origin) and without."""
    import numpy as np

    import mpmpp
    from mpmpp.detect_plots import plot_detection
    from mpmpp.report_plots import plot_alarm_timeline

    detector = mpmpp.Detector.load(os.path.join(STREAM, "detector.json"))
    result = detector.monitor(mpmpp.load_data(DATA, detector.model))
    assert result.alarms
    for origin in (None, np.datetime64("2024-03-31T00:30:00", "ms")):
        path = tmp_path / f"detection_{origin is None}.png"
        plot_detection(result, path, origin=origin)
        assert ink(path)[1] > 20
        timeline = tmp_path / f"timeline_{origin is None}.png"
        timeline.write_bytes(plot_alarm_timeline(result, origin))
        assert ink(timeline)[1] > 20


def test_moving_rms_against_a_plain_loop():
    import numpy as np

    from mpmpp.report_plots import moving_rms

    rng = np.random.default_rng(3)
    e = rng.standard_normal(200)
    e[[5, 50, 51, 52]] = np.nan
    n = 9
    expected = []
    for k in range(len(e)):
        window = e[max(0, k - n // 2): k + n // 2 + 1]
        present = window[np.isfinite(window)]
        expected.append(np.sqrt(np.mean(present ** 2)) if len(present) >= n / 2 else np.nan)
    np.testing.assert_allclose(moving_rms(e, n), expected, rtol=1e-12)


def test_a_model_without_noise_model_is_compared_through_the_estimated_disturbance(tmp_path):
    """The page's compare section says when an output's errors are taken through a disturbance
    model estimated from the data (a hand-written FOPTD model of a PI flow loop, 2 h at 10 s)."""
    import mpmpp
    import pi_loop

    loop = pi_loop.FLOW
    g = mpmpp.TransferFunction.from_foptd(loop.gain, loop.time_constant_s, loop.dead_time_s, 10.0)
    mpmpp.save_model(mpmpp.Model("flow", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}}, {}), tmp_path / "model.json")
    pi_loop.simulate(loop, 0, setpoint_steps=True).to_csv(tmp_path / "data.csv", index=False)
    path = tmp_path / "report.html"
    code, out, err = run_cli("report", tmp_path / "model.json", tmp_path / "data.csv", "-o", path)
    assert code == 0, err
    text = path.read_text(encoding="utf-8")
    compare_part = text[text.index('id="compare"'):text.index('id="diagnose"')]
    assert ('<p class="note">PV: the model has no noise model; its disturbance model was estimated from the data'
            in compare_part)
