"""report.html in a real browser: headless Chromium (Debian's package; `make test` installs it when it can).

Chromium prints every console message of the page to stderr as a
``CONSOLE`` log line (with --enable-logging=stderr); --dump-dom prints the
DOM after the page's scripts ran, so plotly's rendered SVG shows there.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]
SECTIONS = ("summary", "setup", "classifier", "scenarios", "timing", "over-time", "cardinality", "trajectories")

pytestmark = pytest.mark.skipif(not Path(CHROMIUM).is_file(), reason=(
    "chromium is not installed: `make test` installs Debian's chromium when run as root with apt-get"))


def chromium(url: str, profile: Path, *args: str) -> subprocess.CompletedProcess:
    """Run headless Chromium on ``url`` with a fresh profile; returns the finished process."""
    return subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                           "--virtual-time-budget=10000", *args, url],
                          capture_output=True, text=True, timeout=60)


def console_messages(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if re.search(r"CONSOLE[:(]", line)]


def test_console_messages_are_seen(tmp_path):
    """The detector below must see a page's console errors, or its silence proves nothing."""
    page = tmp_path / "probe.html"
    page.write_text("<html><body><script>console.error('probe-error'); undefinedCall();</script></body></html>")
    messages = console_messages(chromium(page.as_uri(), tmp_path / "profile", "--dump-dom").stderr)
    assert any("probe-error" in m for m in messages) and any("undefinedCall" in m for m in messages)


def test_report_renders_every_section_and_plot_without_console_errors(study_dir, tmp_path):
    url = (study_dir / "report.html").as_uri()
    run = chromium(url, tmp_path / "profile", "--dump-dom")
    assert run.returncode == 0, run.stderr[-2000:]
    assert console_messages(run.stderr) == []
    dom = run.stdout
    for ident in SECTIONS:
        assert f'<section id="{ident}">' in dom
    assert dom.count("<img ") == 8 and dom.count("<table") >= 7
    for scenario in ("pair", "S4"):  # plotly drew each trajectory plot: its div is marked and holds the SVG
        start = dom.index(f'id="trajectories-{scenario}"')
        assert "js-plotly-plot" in dom[dom.rindex("<div", 0, start):dom.index(">", start)]
        rest = dom[start:]
        end = min(i for i in (rest.find('id="trajectories-', 1), rest.find("</section>")) if i > 0)
        assert 'class="main-svg"' in rest[:end] and "scatterlayer" in rest[:end]
    shot = tmp_path / "report.png"
    run = chromium(url, tmp_path / "profile2", "--window-size=1280,4000", "--hide-scrollbars", f"--screenshot={shot}")
    assert run.returncode == 0 and shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


#: the first screen of a laptop: the report's headline figure must be in it
SCREEN = (1280, 800)
_PROBE = """<script>window.addEventListener("load", () => {
  const img = document.querySelector('#summary figure img[alt^="GOSPA against time per scan"]');
  const r = img.getBoundingClientRect();
  document.body.setAttribute("data-headline", [r.left, r.top, r.right, r.bottom, window.innerWidth,
                                               window.innerHeight, img.naturalWidth].join(","));
  const links = [...document.querySelectorAll("nav.toc a")];
  document.body.setAttribute("data-toc", [links.length,
    links.filter(a => document.getElementById(a.getAttribute("href").slice(1))).length].join(","));
  // a table taller than its box scrolls inside it, its header row staying at the box's top
  const box = [...document.querySelectorAll("div.table")].find(d => d.scrollHeight > d.clientHeight + 100);
  box.scrollTop = 100;
  const head = box.querySelector("thead th").getBoundingClientRect().top - box.getBoundingClientRect().top;
  document.body.setAttribute("data-sticky", [box.scrollTop, head].join(","));
});</script>"""


def test_the_headline_figure_is_on_the_first_screen(study_dir, tmp_path):
    import numpy as np
    from PIL import Image

    page = tmp_path / "report.html"  # a copy beside nothing: the page needs no sibling files
    page.write_text((study_dir / "report.html").read_text().replace("</body>", _PROBE + "</body>"))
    size = f"--window-size={SCREEN[0]},{SCREEN[1]}"
    run = chromium(page.as_uri(), tmp_path / "profile", size, "--force-device-scale-factor=1", "--dump-dom")
    assert run.returncode == 0 and console_messages(run.stderr) == [], run.stderr[-2000:]
    left, top, right, bottom, width, height, natural = map(float, re.search(r'data-headline="([^"]+)"',
                                                                            run.stdout).group(1).split(","))
    assert natural > 0  # the image decoded
    assert 0 <= left < right <= width and 0 <= top < bottom <= height  # wholly within the first screen
    assert right - left >= 0.6 * width  # and not shrunk to a thumbnail
    links, resolved = map(int, re.search(r'data-toc="([^"]+)"', run.stdout).group(1).split(","))
    assert links == resolved >= len(SECTIONS)  # the table of contents links every section
    scrolled, head = map(float, re.search(r'data-sticky="([^"]+)"', run.stdout).group(1).split(","))
    assert scrolled == 100 and abs(head) < 1  # the header row stuck to the top of its scrolled box

    shot = tmp_path / "first-screen.png"
    run = chromium(page.as_uri(), tmp_path / "profile2", size, "--force-device-scale-factor=1", "--hide-scrollbars",
                   f"--screenshot={shot}")
    assert run.returncode == 0, run.stderr[-2000:]
    pixels = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert pixels.shape[1] == SCREEN[0] and pixels.std() > 10  # not blank
    figure = pixels[int(top):int(bottom), int(left):int(right)]
    assert (figure < 128).mean() > 0.005 and (figure > 250).mean() > 0.3  # the plot's ink on its white ground
