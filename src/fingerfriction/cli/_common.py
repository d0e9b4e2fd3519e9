"""What every command shares: the two consoles, one-line errors, ``--finger`` files, and
the console of the long commands (``--verbose``/``--quiet``, grouped warnings, one
summary line)."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.markup import escape

from .._check import check_option
from .._console import one_line

console = Console()
err_console = Console(stderr=True)


#: Exit statuses, the same for every command (README, "Exit status"): 0 when everything
#: asked for is done and every trial is ok; 1 when some trials failed (or their inputs
#: are missing: results kept) while the rest was done, its output written and a summary
#: printed; 2 for a usage or input error (a bad option, an unreadable study, a results
#: folder in use...): nothing, or nothing more, was done.
EXIT_OK, EXIT_SOME_FAILED, EXIT_ERROR = 0, 1, 2


def fail(message: str) -> None:
    """Print a one-line error and exit with status 2 (:data:`EXIT_ERROR`)."""
    text = " ".join(str(message).split())
    err_console.print(f"[bold red]error:[/] {escape(text)}", highlight=False, soft_wrap=True)
    raise typer.Exit(EXIT_ERROR)


def bounded(lo: float, hi: float, unit: str = ""):
    """A typer option callback that keeps the option's value (when given) in ``[lo, hi]``:
    every size, step and count a user gives has a bound, and a value outside it is a
    one-line error naming the option (exit status 2). NaN is outside every range."""
    def check(param: typer.CallbackParam, value):
        if value is None:
            return value
        values = value if isinstance(value, (list, tuple)) else [value]
        for v in values:
            if not lo <= v <= hi:
                name = param.opts[0] if param.opts else param.name
                fail(f"{name} must be in [{lo:g}, {hi:g}]{' ' + unit if unit else ''}, got {v!r}")
        return value

    check.bounds = (lo, hi, unit)
    return check


#: Bounds shared by several commands.
SEED = bounded(0, 2**32 - 1)
WORKERS = bounded(1, 256, "workers")
STEP_MM = bounded(0.001, 1.0, "mm")
LOAD_N = bounded(0.001, 10.0, "N")
SUBJECT = bounded(1, 99)


class FieldDefault(str):
    """What ``--help`` shows as the default of an option whose own default is None, meaning
    "the default of the options dataclass": that field's default, looked up when the help
    is formatted (the command line imports a stage only when a command runs, or its help
    is shown), so the value is written once, in the dataclass.

    ``FieldDefault("fingerfriction.fit.paper_results:FitOptions.median_kernel")``: a module
    and a dataclass's field; a function's keyword (``"fingerfriction.pipeline.fitting:fit.model"``)
    or any attribute (``"fingerfriction.fit.paper:MU_GRID[0]"`` takes an item, ``[position]`` a
    key) for a default
    that is not a dataclass's. Pass it as ``show_default`` (:func:`dataclass_option`).
    """

    def value(self):
        """The default itself (imports its module)."""
        import dataclasses  # small; kept beside its one use
        import importlib  # small; kept beside its one use
        import inspect  # small; kept beside its one use

        module, _, path = str.__str__(self).partition(":")
        index = None
        if path.endswith("]"):
            path, _, item = path[:-1].partition("[")
            index = int(item) if item.isdigit() else item  # a tuple's item, or a dict's key
        owner_path, _, name = path.rpartition(".")
        obj = importlib.import_module(module)
        for part in filter(None, owner_path.split(".")):
            obj = getattr(obj, part)
        field = next((f for f in dataclasses.fields(obj) if f.name == name), None) \
            if dataclasses.is_dataclass(obj) else None
        if field is None and callable(obj) and not isinstance(obj, type):  # a function's keyword
            value = inspect.signature(obj).parameters[name].default
        elif field is None:
            value = getattr(obj, name)
        elif field.default is not dataclasses.MISSING:
            value = field.default
        else:
            value = field.default_factory()
        return value if index is None else value[index]

    def text(self) -> str:
        v = self.value()
        if isinstance(v, bool):
            return "on" if v else "off"
        if isinstance(v, float):
            return f"{v:g}"
        if isinstance(v, (tuple, list)):
            return ",".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v)
        return "none" if v is None else str(v)

    def __str__(self) -> str:
        return self.text()

    def __format__(self, spec: str) -> str:
        return format(self.text(), spec)


def dataclass_option(field: str, *names: str, **kwargs):
    """A ``typer.Option`` that defaults to None, "the dataclass default": ``--help`` shows the
    default of ``field`` (a :class:`FieldDefault` path), which the command leaves to the
    dataclass when the option is not given."""
    return typer.Option(None, *names, show_default=FieldDefault(field), **kwargs)


#: The force stage's parameters, whose fields the force options default to.
FORCE_PARAMS = "fingerfriction.forces.params:ForceProcessingParams"


def highpass_options() -> dict:
    """The force sensor's high-pass options of ``forces`` and ``analyze`` (typer parameters by
    name; each defaults to the dataclass's value): ``--highpass-model``, ``--highpass-hz``,
    ``--estimate-highpass``. :func:`highpass_params` turns the given ones into
    :class:`~fingerfriction.forces.ForceProcessingParams` keywords."""
    return {
        "highpass_model": dataclass_option(
            f"{FORCE_PARAMS}.highpass_model", "--highpass-model",
            help="the force sensor's high-pass to invert: first-order (one pole at --highpass-hz, both "
                 "forces) or second-order (each channel's two-pole response, estimated on the rests "
                 "before the touch and after the lift-off; --highpass-hz is its prior)"),
        "highpass_hz": dataclass_option(
            f"{FORCE_PARAMS}.sensor_highpass_hz", "--highpass-hz",
            help="sensor high-pass cut-off to invert, Hz (the prior with --estimate-highpass or "
                 "--highpass-model second-order); 0: none", callback=bounded(0.0, 1000.0, "Hz")),
        "estimate_highpass": typer.Option(
            False, "--estimate-highpass", help="fit the first-order sensor's cut-off on the rests "
                                               "(--highpass-hz: the prior)"),
    }


def highpass_params(highpass_model: str | None, highpass_hz: float | None, estimate_highpass: bool) -> dict:
    """The given high-pass options (:func:`highpass_options`) as force-parameter keywords;
    ``--highpass-hz 0`` is no compensation. An unknown model is a ValueError naming the option."""
    from ..forces.params import HIGHPASS_MODELS  # the force stage's (numpy): when a command runs

    if highpass_model is not None:
        check_option("--highpass-model", highpass_model, HIGHPASS_MODELS)
    kw = given(highpass_model=highpass_model)
    if highpass_hz is not None:
        kw["sensor_highpass_hz"] = highpass_hz or None
    if estimate_highpass:
        kw["estimate_highpass"] = True
    return kw


def or_default(value, field: str):
    """``value``, or the default of ``field`` (a :class:`FieldDefault` path) when it is None: for
    a command that prints the value it used."""
    return FieldDefault(field).value() if value is None else value


def given(**options) -> dict:
    """The options that were given (not None), as keywords: the others are left to the
    dataclass's defaults."""
    return {k: v for k, v in options.items() if v is not None}


def finish(all_ok: bool) -> None:
    """End a command that ran: exit status 0 if ``all_ok``, else 1 (:data:`EXIT_SOME_FAILED`)."""
    if not all_ok:
        raise typer.Exit(EXIT_SOME_FAILED)


def read_fingers(path: str | None = None, items: list[str] | None = None, model: str = "halfspace"):
    """``--finger FILE`` (a finger) or ``--finger SUBJECT=FILE`` items (a dict), one-line errors;
    ``model='fe'`` reads FE finger files."""
    from ..mechanics import finger_file  # small, but only when --finger is given

    try:
        if path is None:
            return finger_file.read_subject_fingers(items, model=model)
        return finger_file.read_finger_file(path, model=model)
    except ValueError as exc:
        fail(str(exc))


# ---------------------------------------------------------------------------------------
# the console of the long commands: --verbose / --quiet, grouped warnings, one summary line
# ---------------------------------------------------------------------------------------

VERBOSE = typer.Option(False, "--verbose", "-v", help="Show every log record and every failure as it comes.")
QUIET = typer.Option(False, "--quiet", "-q", help="Print only the summary line.")


def verbosity_of(verbose: bool, quiet: bool) -> int:
    """-1 quiet, 0 normal, 1 verbose."""
    if verbose and quiet:
        fail("--verbose and --quiet exclude each other")
    return 1 if verbose else -1 if quiet else 0


def show_progress(verbosity: int) -> bool:
    """Progress bars on an interactive terminal only: in a log file they are noise."""
    return verbosity >= 0 and err_console.is_terminal


def echo(text: str) -> None:
    err_console.print(escape(text), highlight=False, soft_wrap=True)


def warn(text: str) -> None:
    err_console.print(f"[yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


def grouped_failures(failures, what: str, verbosity: int, label_of=None) -> None:
    """Failures as one warning line per group (a subject, or all), with a count and one
    example; every failure with ``--verbose``; nothing with ``--quiet``."""
    failures = list(failures)
    if verbosity < 0 or not failures:
        return
    if verbosity > 0:
        for tid, reason in failures:
            warn(f"{what} failed: {tid}: {one_line(reason, 300)}")
        return
    groups: dict = {}
    for tid, reason in failures:
        groups.setdefault(label_of(tid) if label_of else "", []).append((tid, reason))
    for label, items in groups.items():
        tid, reason = items[0]
        head = f"{label}: " if label else ""
        warn(f"{head}{len(items)} {what} failure{'s' if len(items) != 1 else ''} "
             f"(e.g. {tid}: {one_line(reason, 120)})")


def plural(count: int, noun: str) -> str:
    """'1 trial', '2 trials'."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def print_summary(text: str) -> None:
    console.print(escape(text), highlight=False, soft_wrap=True)


def csv_list(values: str | None) -> tuple[str, ...] | None:
    return None if not values else tuple(v.strip() for v in values.split(",") if v.strip())


def print_problems(problems) -> None:
    for p in problems:
        err_console.print(escape(str(p)), highlight=False, soft_wrap=True)


