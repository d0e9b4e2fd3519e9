"""The leave-one-surface-out figure when nothing could be predicted."""

import pandas as pd
from PIL import Image

from fingerfriction.pipeline.validation import OutOfSample, write_validation


def test_no_held_out_prediction_still_writes_a_figure_and_the_table(tmp_path):
    # every training fit failed: the table has rows (with their notes) but no estimates
    table = pd.DataFrame({"model": ["paper"], "subject": ["1"], "surface": ["bump-2mm"],
                          "rho_in_sample": [float("nan")], "rho_out_of_sample": [float("nan")]})
    write_validation(OutOfSample(table=table, estimates={}), tmp_path / "loso.csv")
    assert (tmp_path / "loso.csv").read_text().startswith("model,subject,surface")
    with Image.open(tmp_path / "loso.png") as im:
        assert im.size[0] > 100 and im.size[1] > 50


def test_a_forward_sweep_is_solved_once_per_process_and_read_only(monkeypatch):
    from types import SimpleNamespace

    import numpy as np

    from fingerfriction.pipeline import validation as v
    from fingerfriction.surfaces import get_surface

    calls = []

    def fake(surf, finger, xs, *, load, contact):
        calls.append(len(xs))
        return np.zeros((len(xs), 1, 2))

    monkeypatch.setattr(v, "forward_regions", fake)
    monkeypatch.setattr(v, "_sweep_memo", type(v._sweep_memo)())
    trials = [SimpleNamespace(x=np.array([-3.0, 3.0]))]
    surf = get_surface("bump-2mm")
    first = v._forward_sweep({}, surf, "finger-a", trials, load=0.3, contact="geometric", step=0.5)
    again = v._forward_sweep({}, surf, "finger-a", trials, load=0.3, contact="geometric", step=0.5)
    assert calls == [13] and again[2] is first[2]  # a second call (another fit) reuses it
    assert not first[2].flags.writeable
    v._forward_sweep({}, surf, "finger-b", trials, load=0.3, contact="geometric", step=0.5)
    assert calls == [13, 13]  # another finger is another sweep
    monkeypatch.setattr(v, "SWEEP_MEMO_SIZE", 1)
    v._forward_sweep({}, surf, "finger-c", trials, load=0.3, contact="geometric", step=0.5)
    assert len(v._sweep_memo) == 1  # bounded
