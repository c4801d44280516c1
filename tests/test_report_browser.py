"""The compare report in a real browser: headless Chromium (Debian's ``chromium``, installed
by ``make install-test`` when run as root) loads index.html at a laptop's and a phone's width;
a script put into a copy of the page records errors and measures the layout into the DOM,
which ``--dump-dom`` returns. No console errors, no horizontal overflow, the verdict table
on the first screen of a laptop."""

from __future__ import annotations

import functools
import html
import http.server
import json
import re
import shutil
import subprocess
import threading

import pytest

from trebuchet.ingest.compare import CompareOptions
from trebuchet.report.compare_cli import compare_report

from .conftest import HORSDAL, ROOT

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="no chromium: `make install-test` installs Debian's chromium when "
    "run as root (or: apt-get install chromium); the browser test needs it")

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run",
         "--hide-scrollbars", "--virtual-time-budget=5000"]

# caught in the page itself, from its first line: script errors, resources that fail to load
# and console.error calls
CATCH = """<script>
window.__errors = [];
window.addEventListener('error', function (e) {
  var what = e.target && (e.target.src || e.target.href);
  window.__errors.push(e.message || ('cannot load ' + what));
}, true);
(function () {
  var original = console.error;
  console.error = function () { window.__errors.push(Array.from(arguments).join(' '));
                                 original.apply(console, arguments); };
})();
</script>"""

# the page in a frame of the width asked (a browser window is at least 500 px wide), measured
# when loaded; the result written into the DOM that --dump-dom prints
PROBE = """<!DOCTYPE html><html><head><meta charset="utf-8"></head><body style="margin:0">
<iframe id="page" src="page.html" style="border:0;width:WIDTHpx;height:HEIGHTpx"></iframe>
<script>
document.getElementById('page').addEventListener('load', function () {
  var w = this.contentWindow, d = this.contentDocument;
  var table = d.querySelector('table.main');
  var box = table.getBoundingClientRect();
  var images = Array.from(d.images);
  var out = {
    errors: w.__errors,
    viewport: w.innerWidth,
    page_width: d.documentElement.scrollWidth,
    table_right: box.right, table_bottom: box.bottom + w.scrollY,
    table_scroll: table.scrollWidth, table_client: table.clientWidth,
    images_loaded: images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length,
    images: images.length,
  };
  var pre = document.createElement('pre');
  pre.id = 'measured';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script></body></html>"""


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("browser") / "report"
    compare_report(ROOT / "data_samples" / "horsdal_240fps.csv", HORSDAL, out,
                   options=CompareOptions(chance_runs=2))
    page = (out / "index.html").read_text(encoding="utf-8")
    (out / "page.html").write_text(page.replace("<head>", "<head>" + CATCH, 1),
                                   encoding="utf-8")
    handler = functools.partial(_Quiet, directory=str(out))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield out, f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:
        pass


def measure(report, tmp_path, width: int, height: int = 900) -> dict:
    out, url = report
    name = f"probe-{width}x{height}.html"
    (out / name).write_text(PROBE.replace("WIDTH", str(width)).replace("HEIGHT", str(height)),
                            encoding="utf-8")
    result = subprocess.run(
        [CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / f'profile-{width}'}",
         "--window-size=1400,1000", "--dump-dom", f"{url}/{name}"],
        capture_output=True, text=True, timeout=120)
    found = re.search(r'<pre id="measured">(.*?)</pre>', result.stdout, re.S)
    assert found, f"chromium did not run the probe: {result.stderr[-2000:]}"
    return json.loads(html.unescape(found.group(1)))


def test_the_report_has_a_viewport_tag(report):
    assert '<meta name="viewport" content="width=device-width' in (
        report[0] / "index.html").read_text(encoding="utf-8")


@pytest.mark.parametrize("width", [1280, 400])
def test_no_errors_and_no_horizontal_overflow(report, tmp_path, width):
    m = measure(report, tmp_path, width)
    assert m["errors"] == [], m
    assert m["images"] == 7 and m["images_loaded"] == 7, m
    assert m["viewport"] == width, m
    assert m["page_width"] <= width, m  # nothing sticks out sideways (figures scroll in place)
    assert m["table_right"] <= width and m["table_scroll"] <= m["table_client"], m


def test_the_verdict_table_is_on_a_laptops_first_screen(report, tmp_path):
    m = measure(report, tmp_path, 1280, 800)
    assert m["table_bottom"] <= 800, m
