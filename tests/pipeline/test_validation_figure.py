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
