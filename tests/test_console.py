"""The long commands' console (fingerfriction._console): warnings grouped by kind, verbosity."""

from __future__ import annotations

import logging

from fingerfriction._console import console_log, one_line, summary_line, with_ci

log = logging.getLogger("fingerfriction.fit")


def test_warnings_counted_by_kind_not_printed_one_by_one():
    lines = []
    with console_log(0, lines.append) as h:
        for mu in (0.3, 0.4, 0.5):  # the same failure at every grid point and for two trials
            for trial in ("t1", "t2"):
                log.warning("fit failed (subject %s, %s, mu=%g): %s", "1", {"trial": trial}, mu, "p0 < 0")
        logging.getLogger("fingerfriction.study").warning("validation failed: %s", "no training fit")
        log.info("mu grid: %d values", 61)
    assert lines == []  # normal: nothing as it happens
    kinds = h.kinds
    assert [(k.label, k.count) for k in kinds] == [("fit failed", 6), ("validation failed", 1)]
    assert kinds[0].example == "fit failed (subject 1, {'trial': 't1'}, mu=0.3): p0 < 0"
    s = h.summary()
    assert s.startswith("7 logged warnings: 'fit failed' x6 (e.g. fit failed (subject 1") and "x1" in s


def test_verbose_echoes_every_record_and_the_logger_is_restored():
    lines = []
    lg = logging.getLogger("fingerfriction")
    before = (lg.level, lg.propagate, list(lg.handlers))
    with console_log(1, lines.append):
        log.info("grid search over %d values", 61)
        log.warning("fit failed: %s", "p0 < 0")
        log.warning("fit failed: %s", "p0 < 0")
        log.debug("not shown")
    assert lines == ["info: grid search over 61 values", "warning: fit failed: p0 < 0",
                     "warning: fit failed: p0 < 0"]
    assert (lg.level, lg.propagate, list(lg.handlers)) == before


def test_summary_line_and_one_line():
    assert summary_line("report", ["180 trials", "79 trial pages"], elapsed_s=35.4, output="r/report") == \
        "report: 180 trials, 79 trial pages; 35 s; output in r/report"
    assert one_line("a\n  b\tc") == "a b c"
    assert one_line("x" * 200, 20) == "x" * 17 + "..."


def test_a_value_with_its_interval_shows_the_interval_width():
    assert with_ci(0.550031, 0.549972, 0.550091) == "0.55003 [0.54997, 0.55009]"
    assert with_ci(0.55147, 0.54085, 0.56223) == "0.551 [0.541, 0.562]"
    assert with_ci(0.5, 0.5, 0.5) == "0.500 [0.500, 0.500]"
    assert with_ci(0.6, 0.6 - 1e-9, 0.6 + 1e-9) == "0.60000 [0.60000, 0.60000]"  # at most 5 decimals
