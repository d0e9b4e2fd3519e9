"""The check that a script starting worker processes protects its top level.

:func:`~fingerfriction.sim.simulate_study` (a process pool) and
:func:`~fingerfriction.pipeline.analyze.analyze` (a Dask ``LocalCluster``) start worker
processes (``fingerfriction._workers``: ``forkserver``, or ``spawn`` where there is none)
that import the user's script again as ``__mp_main__``. A script that calls
them at its top level, without ``if __name__ == "__main__":``, then runs itself again in
every new process: the pool breaks (``BrokenProcessPool``) or Dask's workers fail to start,
after a long multiprocessing traceback. The check below finds that case before any process
is started and says in one line what to do.

The caller is found on the stack: the frame running the body of the ``__main__`` module
(``co_name == "<module>"``), if any, and its current line. That line is looked up in the
script's syntax tree: inside a top-level ``if __name__ == "__main__":`` block is fine,
anywhere else is the case above. An interactive session, ``python -c``, a notebook or a
script whose source cannot be read has no such frame or file, and nothing is checked;
neither is a package's ``__main__`` run with ``python -m`` (``python -m
fingerfriction.cli``), which multiprocessing never imports again
(``multiprocessing.spawn._fixup_main_from_name``).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path


class MainGuardError(RuntimeError):
    """A function that starts worker processes was called at the top level of a script."""


def _is_main_test(node: ast.expr) -> bool:
    """True for ``__name__ == "__main__"`` (either side)."""
    if not (isinstance(node, ast.Compare) and len(node.ops) == 1 and isinstance(node.ops[0], ast.Eq)):
        return False
    sides = (node.left, node.comparators[0])
    names = [s for s in sides if isinstance(s, ast.Name) and s.id == "__name__"]
    consts = [s for s in sides if isinstance(s, ast.Constant) and s.value == "__main__"]
    return len(names) == 1 and len(consts) == 1


def _guarded(source: str, line: int) -> bool:
    """Whether ``line`` (1-based) of the module ``source`` lies in a top-level main guard."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return True  # not ours to judge
    for node in tree.body:
        if isinstance(node, ast.If) and _is_main_test(node.test):
            if node.lineno <= line <= (node.end_lineno or node.lineno):
                return True
    return False


def check_main_guard(what: str, *, alternative: str = "") -> None:
    """Raise :class:`MainGuardError` when called from the unguarded top level of a script.

    Parameters
    ----------
    what : str
        The public function about to start worker processes, e.g. ``"simulate_study"``.
    alternative : str
        A way to run without worker processes, added to the message (e.g. ``"or pass
        workers=1"``).

    Raises
    ------
    MainGuardError
        One line naming the script, the line of the call and the fix.
    """
    main = sys.modules.get("__main__")
    name = getattr(getattr(main, "__spec__", None), "name", None)
    if name is not None and (name == "__main__" or name.endswith(".__main__")):
        return  # a package's __main__ (python -m): the workers do not import it again
    main_dict = getattr(main, "__dict__", None)
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_globals is main_dict and frame.f_code.co_name == "<module>":
            break
        frame = frame.f_back
    if frame is None:
        return
    path = Path(frame.f_code.co_filename)
    try:
        source = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return
    line = frame.f_lineno
    if _guarded(source, line):
        return
    extra = f", {alternative}" if alternative else ""
    raise MainGuardError(
        f"{what} starts worker processes, which import {path.name} again: put the code of "
        f"{path.name} that calls it (line {line}) under `if __name__ == \"__main__\":`{extra}"
    )
