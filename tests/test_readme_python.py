"""The README's Python code blocks, run in order as one plain script, as a reader would paste
them (in a subprocess, in a temporary folder).

The README asks a script that starts worker processes (``simulate_study``, ``analyze``) to
keep its code under ``if __name__ == "__main__":``; the script here does so. Run without
it, those calls stop with one line saying what to do, not a multiprocessing traceback
(the second test).

Some examples read the reader's own recordings (``trial.cine``, ``forces.tdms``,
``S1_bump.csv``) and the frame times and positions ``t_frames``, ``x_frames``. The script
makes them from the study the README simulated a few blocks earlier, just before the first
block that needs them (``_READERS_OWN``): one trial's video as a Phantom cine, its force
channels as a LabVIEW TDMS file and as a headerless CSV in volts, its true finger positions.
"""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"

#: What the reader brings: written just before the first block that contains the key.
_READERS_OWN = {
    'analyze_video("trial.cine"': '''
        import numpy as np
        from nptdms import ChannelObject, TdmsWriter
        from fingerfriction.video import open_video
        from fingerfriction.video.writers import write_video
        _trial = "studies/tiny/trials/s1-bump-4mm-v080-r1"
        _frames = [c.copy() for _, c in open_video(f"{_trial}/video.mkv").iter_chunks(64)]  # buffers reused
        write_video("trial.cine", np.concatenate(_frames)[::4], fps=250.0)   # every 4th frame
        _f = np.load(f"{_trial}/forces.npz")
        with TdmsWriter("forces.tdms") as _w:
            _w.write_segment([ChannelObject("Piezo", "ai0", _f["F1"]),
                              ChannelObject("Piezo", "ai1", _f["F2"])])
        _truth = np.load("studies/tiny/truth/s1-bump-4mm-v080-r1.npz")
        np.savetxt("S1_bump.csv", np.column_stack([_truth["t_force"], _f["F1"] / 10.0, _f["F2"] / 20.0]),
                   delimiter=";")
        t_frames, x_frames = _truth["t_video"], _truth["x_finger_video"]
    ''',
}


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def _script() -> str:
    body = []
    pending = dict(_READERS_OWN)
    for block in _python_blocks():
        for key in list(pending):
            if key in block:
                body.append(textwrap.dedent(pending.pop(key)))
        body.append(block)
    assert not pending, f"no README block contains {sorted(pending)}: update _READERS_OWN"
    return 'if __name__ == "__main__":\n' + textwrap.indent("\n".join(body), "    ")


def _run(script: str, cwd: Path, timeout: float) -> subprocess.CompletedProcess:
    (cwd / "example.py").write_text(script, encoding="utf-8")
    return subprocess.run([sys.executable, "example.py"], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout)


def test_the_readme_has_python_examples():
    blocks = _python_blocks()
    assert len(blocks) >= 10
    assert any("simulate_study(" in b for b in blocks) and any("analyze(" in b for b in blocks)


@pytest.mark.slow
def test_the_readme_python_blocks_run_in_order_as_a_script(tmp_path):
    proc = _run(_script(), tmp_path, timeout=1500)
    assert proc.returncode == 0, f"the README's Python examples fail as a script:\n{proc.stderr[-4000:]}"
    assert (tmp_path / "table1.tex").is_file()          # written by the Table 1 example
    assert (tmp_path / "results" / "report" / "index.html").is_file()   # analyze, fit, report
    assert (tmp_path / "loso.csv").is_file()


def _unguarded_call_fails(script: str, cwd: Path, what: str) -> str:
    """Run ``script`` (its line 2 calls ``what`` at the top level); it must exit 1 with one
    line naming the fix, and no multiprocessing traceback. Returns that line."""
    proc = _run(script, cwd, timeout=300)
    assert proc.returncode == 1, proc.stderr[-2000:]
    last = proc.stderr.strip().splitlines()[-1]
    assert f"{what} starts worker processes" in last and 'if __name__ == "__main__":' in last
    assert "(line 2)" in last
    assert "BrokenProcessPool" not in proc.stderr and "bootstrapping" not in proc.stderr
    return last


@pytest.mark.slow
def test_simulate_study_at_the_top_level_of_a_script_says_what_to_do(tmp_path):
    script = ('from fingerfriction.sim import SimOptions, simulate_study\n'
              'simulate_study("studies/tiny", SimOptions(reps=1, speeds=(80.0,)), workers=2)\n')
    assert "workers=1" in _unguarded_call_fails(script, tmp_path, "simulate_study")
    assert not (tmp_path / "studies").exists()  # stopped before anything was written


@pytest.mark.slow
def test_analyze_at_the_top_level_of_a_script_says_what_to_do(tmp_path):
    (tmp_path / "study").mkdir()
    script = ('from fingerfriction.pipeline.analyze import analyze\n'
              'analyze("study", "results", n_workers=2)\n')
    _unguarded_call_fails(script, tmp_path, "analyze")
    assert not (tmp_path / "results").exists()
    # a package's __main__ run with `python -m` (as `python -m fingerfriction.cli`) is never
    # imported again by the workers: no guard needed, the call goes on (here: no such study)
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text("")
    (tmp_path / "pkg" / "__main__.py").write_text(script.replace('"study"', '"missing"'))
    proc = subprocess.run([sys.executable, "-m", "pkg"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert "MainGuardError" not in proc.stderr and "'missing' does not exist" in proc.stderr


def test_the_guard_is_read_from_the_script():
    from fingerfriction._mainguard import _guarded

    src = 'import x\nif __name__ == "__main__":\n    f()\n    g()\nh()\n'
    assert [_guarded(src, n) for n in (1, 3, 4, 5)] == [False, True, True, False]
    assert _guarded("if '__main__' == __name__:\n    f()\n", 2)
    assert not _guarded("if __name__ != '__main__':\n    f()\n", 2)
