"""The study's commands, in the order of its pipeline: check, analyze, fit, report (init is in
:mod:`.init`);
and demo, all of them on the built-in virtual study (``fingerfriction.study``,
``fingerfriction.report``, ``fingerfriction.demo``)."""

from __future__ import annotations

import math
import time

import typer
from rich.markup import escape
from rich.table import Table

from .._check import check_option
from .._console import console_log, one_line, summary_line, with_ci
from .._outputs import output_dir
from ._common import (
    QUIET,
    SEED,
    VERBOSE,
    WORKERS,
    bounded,
    console,
    csv_list,
    dataclass_option,
    echo,
    err_console,
    fail,
    finish,
    given,
    grouped_failures,
    highpass_options,
    highpass_params,
    plural,
    print_problems,
    print_summary,
    show_progress,
    verbosity_of,
    warn,
)


def check_cmd(
    study: str = typer.Argument(..., help="Study folder (with manifest.json), or the manifest."),
    deep: bool = typer.Option(False, "--deep", help="Also run every trial's video analysis and the "
                              "consistency checks between its video and forces (channels, units, clocks, "
                              "surface, video-force offset; docs/selfcheck.md): slow, writes nothing."),
) -> None:
    """Validate a study and list every problem at once: each manifest field of each trial,
    and each recording against its entry (present, readable, frame count and rate, image
    size, force channels, sample count and rate). Exit status 2 if there is any."""
    from ..study.check import check_study  # heavy (video and force readers); imported when run

    if deep:
        _deep_check(study)
        return
    res = check_study(study)
    print_problems(res.problems)
    n_ok = len(res.study.trials) if res.study is not None else 0
    if res.problems:
        whole = "" if res.study is not None else "; the manifest as a whole cannot be read"
        fail(f"{len(res.problems)} problem(s): {n_ok} of {res.n_entries} trials are fine, "
             f"{len(res.by_trial())} have problems{whole}")
    console.print(f"{res.manifest}: {n_ok} trials, no problem found", highlight=False)


def _deep_check(study: str) -> None:
    """``check --deep``: the shallow problems, then each consistency finding of each trial;
    exit status 2 if there is any error (a warning alone keeps 0)."""
    from ..pipeline.selfcheck import deep_check  # heavy (every stage); imported when the command runs

    with console_log(0, echo):
        problems, found = deep_check(study)
    print_problems(problems)
    warnings = [p for p in problems if p.kind == "deep" and p.message.startswith("warning ")]
    errors = [p for p in problems if p not in warnings]
    if errors:
        fail(f"{len(errors)} problem(s) in {len({p.trial for p in errors})} trial(s) and {len(warnings)} "
             f"warning(s); {len(found)} trials analysed")
    more = f", {len(warnings)} warning(s)" if warnings else ""
    console.print(f"{study}: {len(found)} trials analysed, no problem found{more}", highlight=False)


_HP = highpass_options()


def analyze_cmd(
    study: str = typer.Argument(..., help="Study folder (with manifest.json)."),
    out: str = typer.Option(..., "--out", "-o", help="Results folder (created; resumed if it exists)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Address of a running Dask scheduler, "
                                  "e.g. tcp://10.0.0.5:8786 (default: a local cluster on all cores)."),
    workers: int = typer.Option(None, "--workers", "-j", help="Local workers (default: all cores).",
                                callback=WORKERS),
    force: bool = typer.Option(False, "--force", help="Recompute trials that are already finished."),
    window_mm: float = typer.Option(None, "--window-mm", help="Force position window in mm, centred on the "
                                    "feature (default: the paper's 26 mm).",
                                    callback=bounded(1.0, 100.0, "mm")),
    position: str = dataclass_option("fingerfriction.pipeline.params:VIDEO_DEFAULTS[position]", "--position",
                                     help="x(t) estimator: hybrid (chord midpoint, else an outline edge) or "
                                          "cf-centroid (the paper's C_f centroid) or chord."),
    simulated: bool = typer.Option(False, "--simulated", help="Options for studies of the virtual "
                                   "experiment (only matter with --position cf-centroid: narrower window, "
                                   "x(t) extended; see README)."),
    dry_run: bool = typer.Option(False, "--dry-run", help="List the trials that would be computed and why "
                                 "(new, input changed, manifest entry changed, parameters changed); run "
                                 "and write nothing."),
    quick_resume: bool = typer.Option(False, "--quick-resume", help="Trust an input whose size, times and "
                                      "inode are those recorded instead of hashing its content (faster on "
                                      "large studies; misses edits on file systems without status-change "
                                      "times)."),
    sync: str = dataclass_option("fingerfriction.selfcheck.flags:SelfCheckParams.sync", "--sync",
                                 help="Video-force clock offset: check (measure it from the start of each "
                                      "slide and fail a trial whose manifest offset is off), auto (use the "
                                      "measured offset) or manifest (trust the manifest)."),
    highpass_model: str = _HP["highpass_model"],
    highpass_hz: float = _HP["highpass_hz"],
    estimate_highpass: bool = _HP["estimate_highpass"],
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Every trial through video analysis, the consistency checks and force processing, in
    parallel (resumable).

    The study is checked first (as `fingerfriction check`): mistakes in the manifest stop
    the run; a trial whose recordings do not match its entry fails, the others go on. A
    finished trial is computed again when its input files, its manifest entry or the
    analysis parameters changed."""
    from ..pipeline.analyze import StudyCheckError, analyze, plan_analysis  # heavy (Dask, both stages)
    from ..pipeline.params import POSITIONS, AnalysisParams, sim_params  # heavy (both stages), as above
    from ..selfcheck import SYNC_MODES  # heavy (both stages), as above

    try:
        if position is not None:
            check_option("--position", position, POSITIONS)
        if sync is not None:
            check_option("--sync", sync, SYNC_MODES)
        opts = sim_params(**given(position=position)) if simulated else \
            {"video": given(position=position), "forces": {}}
        opts["selfcheck"] = given(sync=sync)
        if window_mm is not None:
            opts["forces"]["window_mm"] = window_mm
        opts["forces"].update(highpass_params(highpass_model, highpass_hz, estimate_highpass))
        params = AnalysisParams(**opts)
        params.resolved()  # the options checked together (a ValueError) before any folder is read
        verbosity = verbosity_of(verbose, quiet)
        if dry_run:
            plan = plan_analysis(study, out, params=params, force=force, quick_resume=quick_resume)
        else:
            with console_log(verbosity, echo) as log:
                res = analyze(study, out, scheduler=scheduler, n_workers=workers, force=force,
                              progress=show_progress(verbosity), params=params, quick_resume=quick_resume)
    except StudyCheckError as exc:
        print_problems(exc.problems)
        fail(f"{len(exc.problems)} problem(s) in the manifest; nothing was run")
    except (ValueError, OSError) as exc:
        fail(str(exc))
    if dry_run:
        for p in plan.trials:
            console.print(f"{p.trial_id}: {p.action} ({p.reason})", highlight=False, soft_wrap=True)
        console.print(f"would compute {len(plan.todo)} and skip {len(plan.skipped)} of {len(plan.trials)} "
                      "trials; nothing was run or written", highlight=False)
        return
    grouped_failures(res.failures, "analysis", verbosity)
    if res.input_missing and verbosity >= 0:
        tid, why = res.input_missing[0]
        warn(f"{plural(len(res.input_missing), 'trial')} with input files missing or unreadable: their last "
             f"results are kept, marked 'input missing' (e.g. {tid}: {one_line(why, 120)})")
    missing = [f"{len(res.input_missing)} input missing (last results kept)"] if res.input_missing else []
    print_summary(summary_line(
        "analyze", [f"{res.n_computed} computed", f"{res.n_skipped} already done", *missing,
                    f"{res.n_failed} failed of {plural(res.n_trials, 'trial')}",
                    f"{res.scheduler} scheduler, {res.n_workers} workers", _sync_fact(res.sync)],
        elapsed_s=res.elapsed_s, output=str(res.results), log=log))
    finish(res.success)


def _sync_fact(sync: dict) -> str:
    """The summary's word on the video-force synchronisation (``--sync``)."""
    trials = (sync or {}).get("trials") or {}
    if not trials:
        return ""
    checks = [t.get("check") or {} for t in trials.values()]
    if sync.get("mode") == "auto":
        moved = [c for c in checks if c.get("level") == "warning"]
        if not moved:
            return f"sync auto: {plural(len(trials), 'trial')} within a few frames of the manifest"
        worst = max(moved, key=lambda c: abs(c.get("figure") or 0.0))
        return (f"sync auto: {plural(len(moved), 'trial')} moved by more than a few frames (up to "
                f"{worst.get('figure', 0.0):+.1f} ms): the manifest's clocks disagree")
    off = sum(c.get("level") == "error" for c in checks)
    return f"sync checked: {off} of {plural(len(trials), 'trial')} off the video's clock"


_FIT = "fingerfriction.pipeline.fitting"
_GRID = "fingerfriction.fit.paper:MU_GRID"


def fit_cmd(
    results: str = typer.Argument(..., help="Results folder written by `fingerfriction analyze`."),
    model: str = dataclass_option(f"{_FIT}:fit.model", "--model",
                                  help="auto (the variant the data support, or none: exit status 1), or a "
                                       "variant to use: load, pressure, interlock or paper; every variant is "
                                       "fitted and compared."),
    method: str = dataclass_option("fingerfriction.fit.variants:FitSettings.method", "--method",
                                   help="Paper model's p0, p1 fit: lstsq or nelder-mead (the paper's)."),
    mu_min: float = dataclass_option(f"{_GRID}[0]", "--mu-min", help="Smallest mu of the paper model's grid.",
                                     callback=bounded(0.0, 5.0)),
    mu_max: float = dataclass_option(f"{_GRID}[1]", "--mu-max", help="Largest mu of the paper model's grid.",
                                     callback=bounded(0.0, 5.0)),
    mu_step: float = dataclass_option(f"{_GRID}[2]", "--mu-step",
                                      help="Step of the paper model's mu grid (at most 10001 values).",
                                      callback=bounded(1e-4, 1.0)),
    median: int = dataclass_option("fingerfriction.fit.paper_results:FitOptions.median_kernel", "--median",
                                   help="Median filter window on the models, samples (odd; 1 = off).",
                                   callback=bounded(1, 1001, "samples")),
    seed: int = dataclass_option(f"{_FIT}:fit.seed", "--seed", callback=SEED,
                                 help="Seed of the bootstrap confidence intervals."),
    validate: bool = typer.Option(True, "--validate/--no-validate",
                                  help="Validate every variant out of sample (leave one surface out, "
                                       "fit/loso.csv); --no-validate skips it, faster: the choice then "
                                       "rests on Table 1 alone."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Every model variant: mu per subject, per-trial parameters, Table 1 with CIs, the
    out-of-sample comparison, the variant the data support (or its rejection), flags.
    Exit status 1 when every variant is rejected."""
    from ..pipeline.fitting import fit  # heavy (scipy, the forward model); imported when the command runs
    from ..study.store import ResultsStore  # heavy (pandas, scipy); imported when the command runs

    verbosity = verbosity_of(verbose, quiet)
    t0 = time.perf_counter()
    try:
        with console_log(verbosity, echo) as log, _holding(results, "fit"):
            res = fit(results, mu_grid=(mu_min, mu_max, mu_step), progress=show_progress(verbosity),
                      validate=validate, **given(model=model, method=method, median_kernel=median, seed=seed))
    except (ValueError, OSError) as exc:
        fail(str(exc))
    store = ResultsStore(results)
    _fit_warnings(res, store, verbosity)
    if verbosity >= 0:
        _print_fit_tables(res.model, res.table1, res.loso, res.selection.comparison, res.notes, res.rejected)
    _print_choice(res.selection, res.requested, verbosity)
    print_summary(summary_line("fit", _fit_facts(res), elapsed_s=time.perf_counter() - t0,
                          output=str(store.fit_dir), log=log))
    finish(res.n_failed == 0 and not res.rejected)


def _holding(results: str, command: str):
    """The results folder held for one command (``analyze`` holds it too): a second command
    writing it meanwhile is refused, naming the first. A folder that is not a results folder
    is left to the command to refuse (nothing is created in it)."""
    from contextlib import nullcontext  # small; kept beside its one use

    from ..study.store import ResultsStore  # heavy (pandas, scipy); imported when the command runs

    store = ResultsStore(results)
    return store.lock(command) if store.run_path.is_file() else nullcontext()


def _mu_text(res) -> str:
    """Each subject's mu of a FitSummary with its confidence interval (where it has one)."""
    def one(s, m) -> str:
        lo, hi = res.mu_ci.get(s, (math.nan, math.nan))
        if m != m:
            return "not measured"
        return with_ci(m, lo, hi) if lo == lo and hi == hi else f"{m:.3f}"

    return ", ".join(f"{one(s, m)} (subject {s})" for s, m in res.mu.items())


def _fit_facts(res) -> list[str]:
    """The fit's summary: trials, models, mu per subject with its CI, flags, validation."""
    n_err = sum(f.level == "error" for f in res.flags)
    mu = _mu_text(res)
    n_warn = sum(f.level == "warning" for f in res.flags)
    val = ("validated (leave one surface out)" if res.loso is not None
           else f"not validated: {res.loso_message}")
    how = ("MODEL REJECTED" if res.rejected else "chosen by --model auto") if res.requested == "auto" \
        else f"forced{', MODEL REJECTED' if res.rejected else ''}"
    return [plural(res.n_trials, "trial"), f"{res.model} model used ({how})", f"mu {mu}",
            f"{res.n_failed} failed", f"{n_err} error flags, {n_warn} warnings", val]


def _fit_warnings(res, store, verbosity: int) -> None:
    """One warning line per subject: the flags of the variant used, grouped by kind, each
    with a count and one example (with --verbose: each subject's and model's summary line and
    every flag, the comparison variants' as notes); trials that could not be prepared for the
    fit, one line. Flags of level 'info' and the study-level rejection are printed elsewhere."""
    if verbosity < 0:
        return
    unread = [(t, r) for t, r in res.failures if not any(f.trial == t for f in res.flags)]
    if verbosity > 0:
        for line in res.lines:
            echo(line)
        for f in res.flags:
            where = f.trial or (f"subject {f.subject}" if f.subject else "study")
            warn(f"{f.level} {f.code} ({f.model or 'study'} model) {where}: {one_line(f.message, 300)}")
        for f in res.notes:
            where = f.trial or (f"subject {f.subject}" if f.subject else "study")
            echo(f"note on the comparison: {f.level} {f.code} ({f.model} model) {where}: "
                 f"{one_line(f.message, 300)}")
        for tid, reason in unread:
            warn(f"not fitted: {tid}: {one_line(reason, 300)}")
        return
    if unread:
        warn(f"{plural(len(unread), 'trial')} could not be prepared for the fit (e.g. {unread[0][0]}: "
             f"{one_line(unread[0][1], 100)})")
    by_subject: dict = {}
    for f in res.flags:
        if f.level in ("error", "warning") and f.code != "model-rejected":
            by_subject.setdefault(f.subject or "", {}).setdefault((f.model, f.code), []).append(f)
    for subj, groups in by_subject.items():
        parts = []
        for (model, code), fs in groups.items():
            n_tr = len({f.trial for f in fs if f.trial})
            first = fs[0]
            where = f"{first.trial}: " if first.trial else ""
            parts.append(f"{model} model {code}" + (f" in {plural(n_tr, 'trial')}" if n_tr else "")
                         + f" (e.g. {where}{one_line(first.message, 90)})")
        warn((f"subject {subj}: " if subj else "") + "; ".join(parts))


def _print_rejection(reason: str, verbosity: int = 0) -> None:
    """The study-level error of a fit that rejects every model variant, in red (with
    ``--quiet`` the summary line alone says it)."""
    if reason and verbosity >= 0:
        err_console.print(f"[bold red]error: model rejected:[/] {escape(reason)}", highlight=False,
                          soft_wrap=True)


def _print_choice(selection, requested: str = "auto", verbosity: int = 0) -> None:
    """Why ``--model auto`` used the variant it used (one paragraph, after the tables); the
    error of a rejection instead (:func:`_print_rejection`)."""
    if selection.rejected:
        _print_rejection(selection.reason, verbosity)
    elif requested == "auto" and verbosity >= 0:
        console.print(f"model: {escape(selection.reason)}", highlight=False, soft_wrap=True)


def _print_fit_tables(model, table1, loso, comparison, notes=(), rejected: bool = False) -> None:
    """Table 1 of the variant used, titled with its name; the leave-one-surface-out table of
    every variant (a model column); the comparison of the variants, with the notes of those
    not used."""
    from ..fit.variants import get  # the registry's titles
    from ..report.tables import format_p, table1_display  # heavy (matplotlib); when a table is printed

    if table1 is not None and model is not None:
        own = table1[table1["model"] == model] if "model" in table1.columns else table1
        wide = table1_display(own)
        what = (f"Table 1 of {get(model).title} ({model}), REJECTED, shown for reference" if rejected
                else f"Table 1 of the model used, {get(model).title} ({model})")
        t = Table(title=f"{what}: Pearson rho, measured vs model (* p < 0.01)")
        for c in wide.columns:
            t.add_column(str(c))
        for row in wide.itertuples(index=False):
            t.add_row(*[str(v) for v in row])
        console.print(t)
    if loso is not None:
        t = Table(title="Out of sample (leave one surface out): rho per held-out surface, every model")
        for c in ("model", "subject", "held-out surface", "trials", "rho in sample", "rho out of sample",
                  "p out"):
            t.add_column(c)
        for r in loso.itertuples(index=False):
            t.add_row(str(getattr(r, "model", "")), str(r.subject), str(r.surface), str(r.n_trials),
                      f"{r.rho_in_sample:.2f}", f"{r.rho_out_of_sample:.2f}", format_p(r.p_out_of_sample))
        console.print(t)
    if comparison is not None and len(comparison):
        t = Table(title="Which model the data support (every variant fitted to the same trials)")
        for c in ("model", "unphysical", "Table 1 >= 0.75", "held out >= 0.70", "mean held-out rho",
                  "systematic misfit", "verdict"):
            t.add_column(c)
        for r in comparison.itertuples(index=False):
            cells = f"{int(r.loso_cells_ok)} of {int(r.loso_cells)}" if r.loso_cells == r.loso_cells else "-"
            t.add_row(("* " if r.model == model else "") + r.model, f"{r.n_unphysical} of {r.n_trials}",
                      f"{r.table1_cells_ok} of {r.table1_cells}", cells,
                      "-" if r.cv_rho_mean != r.cv_rho_mean else f"{r.cv_rho_mean:.3f}",
                      "-" if r.residual_structure != r.residual_structure else f"{r.residual_structure:.3f}",
                      str(r.verdict))
        console.print(t)
    if notes:
        groups: dict = {}
        for f in notes:
            model_, code = (f.model, f.code) if hasattr(f, "code") else (f["model"], f["code"])
            groups.setdefault((model_, code), []).append(f)
        parts = [f"{m} {code} x{len(fs)}" for (m, code), fs in groups.items()]
        console.print("notes on the comparison variants (not about the study): " + ", ".join(parts),
                      highlight=False, soft_wrap=True)


def _print_tables(rep) -> None:
    _print_fit_tables(rep.model, rep.table1, rep.loso, rep.comparison, rep.notes, bool(rep.rejection))
    t = Table(title="Tactile blind spots (all trials pooled)")
    for c in ("surface", "trials", "start (mm)", "end (mm)", "width (mm)"):
        t.add_column(c)
    for r in rep.blindspots.itertuples(index=False):
        none = r.start_mm != r.start_mm  # NaN: a surface without blind spots
        t.add_row(str(r.surface), str(r.n_trials), "-" if none else f"{r.start_mm:.2f}",
                  "-" if none else f"{r.end_mm:.2f}", "none" if none else f"{r.width_mm:.2f}")
    console.print(t)
    for key, df in rep.truth.items():
        t = Table(title=f"Recovered vs ground truth: {key}")
        for c in df.columns:
            t.add_column("error (%)" if key == "mu" and c == "error" else str(c))
        for row in df.itertuples(index=False):
            t.add_row(*[_truth_cell(key, c, v, row) for c, v in zip(df.columns, row, strict=True)])
        console.print(t)


def _truth_cell(key: str, column: str, value, row) -> str:
    """One cell of a truth table: mu to 5 decimals (a CI can be a few 1e-4 wide) and its
    error relative to the truth in %, other figures to 3 decimals."""
    if not isinstance(value, float):
        return str(value)
    if key == "mu" and column == "error":
        true = getattr(row, "mu_true", math.nan)
        return f"{100.0 * value / true:+.2f}" if true == true and true else "nan"
    return f"{value:.5f}" if key == "mu" else f"{value:.3f}"


def report_cmd(
    results: str = typer.Argument(..., help="Results folder (after analyze; fit for Fig. 6/S3, Table 1)."),
    sample: int = dataclass_option("fingerfriction.report:make_report.sample", "--sample",
                                   callback=bounded(0, 100_000, "trials"),
                                   help="Trial pages for every flagged trial and this many of the others."),
    all_trials: bool = typer.Option(False, "--all-trials", help="A page for every trial."),
    animations: bool = typer.Option(True, "--animations/--no-animations",
                                    help="Overlay animation on each trial page (needs the study's videos)."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Figures (PNG, SVG), Table 1, blind-spot table, a self-contained HTML report and a page
    per flagged (and sampled) trial."""
    from ..report import make_report  # heavy (matplotlib, jinja2); imported when the command runs

    verbosity = verbosity_of(verbose, quiet)
    t0 = time.perf_counter()
    try:
        with console_log(verbosity, echo) as log, _holding(results, "report"):
            rep = make_report(results, progress=show_progress(verbosity), animations=animations,
                              **({"sample": None} if all_trials else given(sample=sample)))
    except (ValueError, OSError) as exc:
        fail(str(exc))
    if verbosity >= 0:
        _print_tables(rep)
        for note in rep.notices:  # e.g. not fitted: said before the path, as at the top of the page
            console.print(f"[bold yellow]note:[/] {escape(note)}", highlight=False, soft_wrap=True)
    _print_rejection(rep.rejection, verbosity)
    kinds: dict = {}
    for f in rep.flags:
        if f["level"] != "info":
            kinds.setdefault(f["code"], []).append(f)
    flagged = " ".join(f"{c} x{len(v)}" for c, v in kinds.items())
    print_summary(summary_line(
        "report", [plural(rep.n_trials + rep.n_failed, "trial"), "not fitted" if not rep.fitted else "",
                   plural(len(rep.pages), "trial page"),
                   f"flags: {flagged}" if flagged else "nothing flagged", f"{len(rep.files)} files"],
        elapsed_s=time.perf_counter() - t0, output=str(rep.html), log=log))
    missing = any(f["code"] == "input-missing" for f in rep.flags)
    finish(rep.n_failed == 0 and not rep.stale_fit and not missing)


def demo(
    out: str = typer.Option("fingerfriction-demo", "--out", "-o",
                            help="Folder for the simulated study and its results (resumed if it exists)."),
    full: bool = typer.Option(False, "--full", help="The paper's 180 trials (default: 36, 1 per condition)."),
    reps: int = typer.Option(None, "--reps", help="Repetitions per condition (overrides --full).",
                             callback=bounded(1, 100)),
    seed: int = dataclass_option("fingerfriction.demo:demo.seed", "--seed", callback=SEED,
                                 help="Seed of the virtual experiment."),
    workers: int = typer.Option(None, "--workers", "-j", help="Worker processes (default: all).",
                                callback=WORKERS),
    subjects: str = typer.Option(None, hidden=True, help="Comma-separated subjects (a smaller design)."),
    surfaces: str = typer.Option(None, hidden=True, help="Comma-separated surfaces (a smaller design)."),
    speeds: str = typer.Option(None, hidden=True, help="Comma-separated speeds in mm/s (a smaller design)."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Simulate the built-in default study, analyze it, fit the model, write the report;
    print Table 1 and the blind-spot table."""
    from ..demo import demo as run_demo  # heavy (every stage); imported when the command runs
    from ..study.store import ResultsStore  # heavy (pandas, scipy); imported when the command runs

    verbosity = verbosity_of(verbose, quiet)
    try:
        design = {}
        for key, val in (("subjects", csv_list(subjects)), ("surfaces", csv_list(surfaces))):
            if val:
                design[key] = val
        if speeds:
            try:
                design["speeds"] = tuple(float(v) for v in csv_list(speeds))
            except ValueError:
                raise ValueError(f"--speeds must be numbers (mm/s) separated by commas, got {speeds!r}") \
                    from None
            if not all(1.0 <= v <= 1000.0 for v in design["speeds"]):
                raise ValueError(f"--speeds must be in [1, 1000] mm/s, got {speeds}")
        output_dir(out, owns={"study", "results"}, what="demo folder (study/, results/)")
        with console_log(verbosity, echo) as log:
            res = run_demo(out, full=full, reps=reps, n_workers=workers, progress=show_progress(verbosity),
                           design=design, **given(seed=seed))
    except (ValueError, OSError) as exc:
        fail(str(exc))
    a, f = res.analysis, res.fit
    grouped_failures(a.failures, "analysis", verbosity)
    _fit_warnings(f, ResultsStore(res.results), verbosity)
    if verbosity >= 0:
        _print_tables(res.report)
    _print_choice(f.selection, f.requested, verbosity)
    t = res.elapsed_s
    print_summary(summary_line(
        "demo", [plural(a.n_trials, "trial"), f"simulate {t['simulate']:.0f} s",
                 f"analyze {t['analyze']:.0f} s ({a.n_computed} computed, {a.n_skipped} already done, "
                 f"{a.n_failed} failed)",
                 f"fit {t['fit']:.0f} s ({f.n_failed} failed, {f.model} model"
                 f"{' REJECTED' if f.rejected else ''}: mu {_mu_text(f)})",
                 f"report {t['report']:.0f} s ({plural(len(res.report.pages), 'trial page')})"],
        elapsed_s=sum(t.values()), output=str(res.report.html), log=log))
    finish(a.success and f.n_failed == 0 and not f.rejected)
