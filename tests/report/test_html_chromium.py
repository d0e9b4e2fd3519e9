"""The HTML report opened in a real browser (headless Chromium) shows its figures.

Chromium comes from Debian's ``chromium`` package; ``.ci/run`` installs it. When it is
missing this test FAILS (it is part of the acceptance), it does not skip. The screenshot
is kept in ``tests/artifacts/`` (gitignored) for a person to look at.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from fingerfriction.report import make_report
from fingerfriction.report.figures import FIGURES

CHROMIUM = "/usr/bin/chromium"
ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"

_PROBE = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 100 && i.naturalHeight > 100; });
  document.body.setAttribute('data-images-total', String(imgs.length));
  document.body.setAttribute('data-images-loaded', String(ok.length));
});
</script>
"""


def _chromium() -> str:
    exe = CHROMIUM if Path(CHROMIUM).exists() else shutil.which("chromium")
    if not exe:
        pytest.fail(
            "headless Chromium is required for the HTML report test but was not found at /usr/bin/chromium; "
            "install Debian's package: apt-get update && apt-get install -y chromium (.ci/run does this)"
        )
    return exe


def _run(exe: str, profile: Path, *args: str) -> subprocess.CompletedProcess:
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={profile}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_report_in_headless_chromium(synthetic_results, tmp_path):
    exe = _chromium()
    results, _ = synthetic_results
    rep = make_report(results)

    # 1. every <img> decodes in the browser (naturalWidth > 0), read back from the DOM
    probe = tmp_path / "probe.html"
    probe.write_text(rep.html.read_text().replace("</body>", _PROBE + "</body>"))
    dom = _run(exe, tmp_path / "profile1", "--virtual-time-budget=10000", "--dump-dom", probe.as_uri())
    assert dom.returncode == 0, dom.stderr[-2000:]
    total = re.search(r'data-images-total="(\d+)"', dom.stdout)
    loaded = re.search(r'data-images-loaded="(\d+)"', dom.stdout)
    assert total and loaded, "the probe script did not run: " + dom.stdout[:500]
    assert int(total.group(1)) == len(FIGURES) + 1  # and the leave-one-surface-out figure
    assert int(loaded.group(1)) == len(FIGURES) + 1

    # 2. a screenshot a person can look at, and it is not blank
    ARTIFACTS.mkdir(exist_ok=True)
    shot = ARTIFACTS / "report_screenshot.png"
    shot.unlink(missing_ok=True)
    res = _run(exe, tmp_path / "profile2", f"--screenshot={shot}", "--window-size=1280,2000",
               "--hide-scrollbars", rep.html.as_uri())
    assert res.returncode == 0 and shot.is_file(), res.stderr[-2000:]
    from matplotlib.image import imread

    img = imread(shot)[..., :3]
    assert img.shape[:2] == (2000, 1280)
    gray = img.mean(axis=2)
    assert gray.std() > 0.05, f"screenshot looks blank (pixel SD {gray.std():.4f})"
    dark = float(np.mean(gray < 0.5))
    assert dark > 0.01, f"almost nothing drawn: {dark:.4f} of pixels are dark"
