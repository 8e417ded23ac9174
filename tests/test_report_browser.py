"""The demo's HTML report rendered in headless Chromium (selenium + chromedriver).

Checks that every section and every figure is present and rendered, that the
page logs no console errors, and saves a screenshot. Skips with the reason
where Chromium, chromedriver or selenium is missing (``make test-all``
installs them: Debian packages ``chromium`` and ``chromium-driver``).
"""

from __future__ import annotations

import importlib.util
import re
import shutil
import tempfile
from pathlib import Path

import pytest

from thermogym.demo import STAGES, Stage, run_demo
from thermogym.demo.report import SECTION_ORDER, stage_anchor

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")

pytestmark = [
    pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt: chromium)"),
    pytest.mark.skipif(
        DRIVER is None, reason="chromedriver is not installed (apt: chromium-driver)"
    ),
    pytest.mark.skipif(
        importlib.util.find_spec("selenium") is None,
        reason="selenium is not installed (pip extra 'browser', installed by make test-all)",
    ),
]


def _driver(profile: Path):
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    # the flags the machine's set-up probe used: no sandbox as root, and no background
    # networking (the closed network refuses Chromium's own connections)
    for flag in (
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        f"--user-data-dir={profile}",
        "--window-size=1280,1000",
    ):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=DRIVER), options=opts)


def check_report_in_browser(out: Path, screenshot: Path) -> dict:
    """Open ``out/report.html``; assert sections, figures, no console errors; screenshot."""
    from selenium.webdriver.common.by import By

    md = (out / "report.md").read_text()
    n_figures = len(re.findall(r"^!\[", md, flags=re.M))
    titles = re.findall(r"^## (\d\..*)$", md, flags=re.M)
    with tempfile.TemporaryDirectory() as profile:
        drv = _driver(Path(profile))
        try:
            drv.get((out / "report.html").resolve().as_uri())
            assert drv.title == "thermogym demo report"
            ids = {e.get_attribute("id") for e in drv.find_elements(By.CSS_SELECTOR, "section")}
            for sec in SECTION_ORDER:
                assert sec in ids, f"section {sec!r} missing"
            stages = drv.find_elements(By.CSS_SELECTOR, "section.stage h2")
            assert [s.text for s in stages] == titles
            imgs = drv.find_elements(By.CSS_SELECTOR, "figure img")
            assert len(imgs) == n_figures
            # every figure decoded: the browser knows its pixel size
            sizes = drv.execute_script(
                "return Array.from(document.images).map(i => [i.complete, i.naturalWidth]);"
            )
            assert sizes and all(c and w > 0 for c, w in sizes), sizes
            # nothing loaded from outside the page
            srcs = [i.get_attribute("src") for i in imgs]
            assert all(s.startswith("data:image/png;base64,") for s in srcs)
            logs = drv.get_log("browser")
            errors = [e for e in logs if e.get("level") in ("SEVERE", "ERROR")]
            assert not errors, errors
            height = drv.execute_script("return document.body.scrollHeight")
            drv.set_window_size(1280, min(int(height) + 100, 16000))
            assert drv.save_screenshot(str(screenshot))
        finally:
            drv.quit()
    assert screenshot.stat().st_size > 10_000
    return {"figures": n_figures, "stages": titles}


def test_small_report_renders_without_errors(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def stage(ctx, res):
        p = ctx.path("figures", "line.png")
        fig, ax = plt.subplots(figsize=(4, 3))
        ax.plot([0, 1, 2], [1, 0, 1])
        fig.savefig(p, format="png")
        plt.close(fig)
        res.figure(ctx.rel(p), "a line with <markup> & `code`")
        res.table(["x | y", "z"], [["`a`", 1.25]], "caption **bold**")
        res.text = "* one\n* two `code`\n\nA paragraph with <script>alert(1)</script>."

    def fails(ctx, res):
        raise RuntimeError("a <b>failure</b> shown as text")

    run_demo(
        tmp_path,
        stages=[Stage("one", "1. One", stage), Stage("two", "2. Two", fails)],
        progress=False,
    )
    got = check_report_in_browser(tmp_path, tmp_path / "report.png")
    assert got == {"figures": 1, "stages": ["1. One", "2. Two"]}


@pytest.mark.slow
def test_quick_demo_report_renders_in_chromium(tmp_path):
    out = tmp_path / "out"
    res = run_demo(out, quick=True, progress=False)
    assert all(r.status == "ok" for r in res), [(r.key, r.error) for r in res]
    got = check_report_in_browser(out, out / "report.png")
    assert len(got["stages"]) == len(STAGES)
    assert got["figures"] >= 2 * len(STAGES)
    html = (out / "report.html").read_text()
    for s in STAGES:
        assert f'id="{stage_anchor(s.key)}"' in html
