"""The HTML report opened in a real browser (headless Chromium): checked in the DOM.

On the report of a small demo (simulated videos, analysed, fitted): every ``<img>``
decodes (naturalWidth > 0); the links to the trial pages resolve; a trial page shows its
animation and its three plots; the warnings block is there when a fit is flagged and
absent when nothing is. Screenshots of the top of the report and of a trial page are written
to the test's temporary folder, or, for a person to look at, to the folder named by the
environment variable ``FINGERFRICTION_TEST_ARTIFACTS`` (nothing is written into the source
tree).

Chromium comes from Debian's ``chromium`` package; ``make test`` installs it when run as
root (``.ci/run``). When it is missing this test FAILS (it is part of the acceptance), it
does not skip.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.report import make_report
from fingerfriction.report.figures import FIGURES
from shared_inputs import once_per_run

CHROMIUM = "/usr/bin/chromium"
#: Where the screenshots are kept for a person to look at (default: the test's tmp_path).
ARTIFACTS_ENV = "FINGERFRICTION_TEST_ARTIFACTS"

#: Runs after load: writes what the DOM holds into attributes of <body> (read from --dump-dom).
_PROBE = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0 && i.naturalHeight > 0; });
  var links = Array.prototype.slice.call(document.querySelectorAll('a.trial-link')).map(
      function (a) { return a.href; });
  var plots = Array.prototype.slice.call(document.querySelectorAll('img.plot')).filter(
      function (i) { return i.naturalWidth > 0; });
  var anim = document.getElementById('animation');
  var warn = document.getElementById('warnings');
  var rej = document.getElementById('model-rejected');
  var heads = Array.prototype.slice.call(document.querySelectorAll('h2'));
  var summary = heads.filter(function (h) { return h.innerText.trim() === 'Summary'; })[0];
  var out = {images_total: imgs.length, images_decoded: ok.length, links: links,
             warnings: !!warn, warnings_text: warn ? warn.innerText : '',
             rejected: !!rej, rejected_text: rej ? rej.innerText : '',
             rejected_above_summary: !!(rej && summary && rej.getBoundingClientRect().top
                                        < summary.getBoundingClientRect().top),
             rejected_visible: !!(rej && rej.getBoundingClientRect().height > 0),
             plots_decoded: plots.length,
             animation: anim ? {w: anim.naturalWidth, h: anim.naturalHeight, src: anim.src.slice(0, 20)}
                             : null};
  document.body.setAttribute('data-probe', JSON.stringify(out));
});
</script>
"""


def _chromium() -> str:
    exe = CHROMIUM if Path(CHROMIUM).exists() else shutil.which("chromium")
    if not exe:
        pytest.fail(
            "headless Chromium is required for the HTML report test but was not found at /usr/bin/chromium; "
            "install Debian's package: apt-get update && apt-get install -y chromium (make test does this as "
            "root)"
        )
    return exe


def _run(exe: str, profile: Path, *args: str) -> subprocess.CompletedProcess:
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--allow-file-access-from-files", f"--user-data-dir={profile}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def _probe(exe: str, page: Path, profile: Path) -> dict:
    """Load ``page`` (a copy beside it, with the probe script, so relative links resolve
    the same) in Chromium and return what the probe found in the DOM."""
    probe = page.with_name(f".probe-{page.name}")
    probe.write_text(page.read_text().replace("</body>", _PROBE + "</body>"))
    try:
        dom = _run(exe, profile, "--virtual-time-budget=15000", "--dump-dom", probe.as_uri())
    finally:
        probe.unlink()
    assert dom.returncode == 0, dom.stderr[-2000:]
    m = re.search(r'data-probe="([^"]*)"', dom.stdout)
    assert m, "the probe script did not run: " + dom.stdout[:500]
    return json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&"))


def _screenshot(exe: str, page: Path, profile: Path, folder: Path, name: str, size=(1280, 1600)) -> Path:
    folder = Path(os.environ.get(ARTIFACTS_ENV) or folder)
    folder.mkdir(parents=True, exist_ok=True)
    shot = folder / name
    shot.unlink(missing_ok=True)
    res = _run(exe, profile, f"--screenshot={shot}", f"--window-size={size[0]},{size[1]}",
               "--hide-scrollbars", page.as_uri())
    assert res.returncode == 0 and shot.is_file(), res.stderr[-2000:]
    from matplotlib.image import imread

    img = imread(shot)[..., :3]
    assert img.shape[:2] == (size[1], size[0])
    gray = img.mean(axis=2)
    assert gray.std() > 0.05, f"{name} looks blank (pixel SD {gray.std():.4f})"
    assert float(np.mean(gray < 0.5)) > 0.01, f"{name}: almost nothing drawn"
    return shot


@pytest.fixture(scope="module")
def demo_report(small_demo, tmp_path_factory):
    """The small demo's results (tests/conftest.py: 1 subject, 2 surfaces, 1 speed: 2
    simulated trials with videos), its report with a page for every trial. Made once per run
    (tests/shared_inputs.py): read-only to the tests, a test that writes into it copies it."""
    demo, _ = small_demo

    def build(folder):
        out = folder / "demo"
        shutil.copytree(demo, out)  # the report is written into the results folder
        return make_report(out / "results", sample=None)

    folder, rep = once_per_run(tmp_path_factory, "demo-report", build)
    return folder / "demo" / "results", rep


@pytest.mark.slow
def test_demo_report_in_headless_chromium(demo_report, tmp_path):
    exe = _chromium()
    results, rep = demo_report
    index = rep.html

    # 1. every <img> of the report decodes in the browser (naturalWidth > 0)
    got = _probe(exe, index, tmp_path / "p1")
    n_fig = sum(p.suffix == ".png" and p.parent == index.parent for p in rep.files)
    n_fig += rep.loso is not None and (results / "fit" / "loso.png").is_file()  # leave one surface out
    assert n_fig >= len(FIGURES) - 2
    assert got["images_total"] == got["images_decoded"] == n_fig
    # the warnings block is there exactly when something is flagged (error or warning)
    assert got["warnings"] == any(f["level"] in ("error", "warning") for f in rep.flags)

    # 2. the links to the trial pages resolve (URLs as the browser resolved them)
    assert got["links"], "no link to a trial page"
    targets = {Path(unquote(urlparse(u).path)) for u in got["links"]}
    for p in targets:
        assert p.is_file(), p
        assert p.parent == index.parent / "trials"
    assert {p.stem for p in targets} == set(rep.pages)

    # 3. a trial page shows its animation and its three plots, decoded
    page = rep.pages[sorted(rep.pages)[0]]
    got = _probe(exe, page, tmp_path / "p2")
    assert got["animation"] is not None and got["animation"]["src"].startswith("data:image/gif")
    assert got["animation"]["w"] > 100 and got["animation"]["h"] > 50
    assert got["plots_decoded"] == 3
    assert got["images_decoded"] == got["images_total"] == 4

    # 4. screenshots for a person to look at
    _screenshot(exe, index, tmp_path / "p3", tmp_path, "report_top.png")
    _screenshot(exe, page, tmp_path / "p4", tmp_path, "report_trial_page.png", size=(1100, 1800))


@pytest.mark.slow
def test_warnings_block_when_a_fit_is_flagged_and_not_otherwise(demo_report, forward_fit, tmp_path):
    exe = _chromium()
    results, _ = demo_report
    # a fit the fit itself flags: the paper's variant forced, its mu grid stopping below the
    # subject's minimum (mu at its bound; a flag of the fit, not of its validation: skipped)
    flagged = tmp_path / "flagged"
    shutil.copytree(results, flagged, ignore=shutil.ignore_patterns(".probe-*"))  # another test's probe
    r = CliRunner().invoke(app, ["fit", str(flagged), "--mu-min", "0.30", "--mu-max", "0.32",
                                 "--model", "paper", "--no-validate"])
    assert r.exit_code in (0, 1), r.output  # 1: every variant rejected (a study-level error)
    rep = make_report(flagged, sample=0, animations=False)
    got = _probe(exe, rep.html, tmp_path / "p1")
    assert got["warnings"] and "mu-at-grid-edge" in got["warnings_text"]
    # synthetic results with the start transient of real slides: both models fit every
    # trial with their parameters inside their bounds, nothing is flagged
    fitted, exit_code, output = forward_fit  # `fit` on them (tests/conftest.py)
    assert exit_code == 0, output
    clean = tmp_path / "clean"
    shutil.copytree(fitted, clean)
    rep = make_report(clean, sample=0, animations=False)
    assert not [f for f in rep.flags if f["level"] != "info"], rep.flags
    # the comparison variants' flags, if any, are notes, not warnings (the console test shows some)
    assert not rep.rejection and all(n["model"] != rep.model for n in rep.notes)
    got = _probe(exe, rep.html, tmp_path / "p2")
    assert got["warnings"] is False and got["rejected"] is False
    assert got["images_decoded"] == got["images_total"] == len(FIGURES) + 1


@pytest.mark.slow
def test_a_rejected_model_is_an_error_at_the_top_of_the_report(rejected_fit, tmp_path):
    """Forces no variant explains: the fit rejects every variant (exit status 1), and the
    report opens with the error and its reason, above the summary, in the browser."""
    exe = _chromium()
    fitted, exit_code, output = rejected_fit  # `fit` on them (tests/conftest.py)
    assert exit_code == 1 and "error: model rejected:" in output, output
    results = tmp_path / "rejected"
    shutil.copytree(fitted, results)
    rep = make_report(results, sample=0, animations=False)
    assert rep.rejection.startswith("no variant passes the bars")
    assert [(f["level"], f["code"]) for f in rep.flags][0] == ("error", "model-rejected")
    got = _probe(exe, rep.html, tmp_path / "p1")
    assert got["rejected"] and got["rejected_visible"] and got["rejected_above_summary"]
    assert "Error: model rejected" in got["rejected_text"]
    assert "no variant passes the bars" in got["rejected_text"]
    assert got["warnings"] and "model-rejected" in got["warnings_text"]
    _screenshot(exe, rep.html, tmp_path / "p2", tmp_path, "report_rejected_top.png")
