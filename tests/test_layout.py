"""The package's layout: its import graph, built with ``ast`` from the sources,
has no cycle and no module imports a higher layer; a function-level import says why on its
line; modules and functions stay within the sizes the project agreed on."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "fingerfriction"
ROOT = "fingerfriction"

#: Layers, lowest first: a module may import its own layer and those below, never above.
#: A name is a module or a package (``study.store``; ``study`` is the package's
#: ``__init__``); a module belongs to the longest name that matches it.
LAYERS = [
    ("base", ["_atomic", "_check", "_console", "_mainguard", "_outputs", "_progress", "_style", "_workers",
              "flags"]),
    ("geometry", ["surfaces", "regions"]),
    ("models", ["model", "mechanics", ""]),  # "": the package root's re-exports
    ("stages", ["fit", "video", "forces", "selfcheck"]),
    ("study data", ["study"]),
    ("experiment and prediction", ["sim", "predict", "testing"]),
    ("one trial", ["pipeline", "pipeline.params", "pipeline.trial"]),
    ("the study's stages", ["pipeline.plan", "pipeline.selfcheck", "pipeline.analyze", "pipeline.fitting",
                            "pipeline.validation", "pipeline.finger_calibration"]),
    ("report", ["report"]),
    ("demo", ["demo"]),
    ("entry points", ["cli"]),
]

#: Functions longer than 80 lines of code (their docstrings not counted), each with why.
LONG_FUNCTIONS = {
    "video/analysis.py:analyze_chunk": "the per-frame kernel of the video stage, kept in one loop for speed",
}

#: Modules over 600 lines, each with why.
LONG_MODULES: dict[str, str] = {}


def _modules() -> dict[str, Path]:
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(PKG).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


MODULES = _modules()


def _resolve(module: str, is_package: bool, node: ast.ImportFrom | ast.Import) -> list[str]:
    """The fingerfriction modules an import statement of ``module`` loads ('' = the root)."""
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names if a.name == ROOT or a.name.startswith(ROOT + ".")]
        return [n[len(ROOT) + 1:] if n != ROOT else "" for n in names]
    if node.level == 0:
        if not (node.module == ROOT or (node.module or "").startswith(ROOT + ".")):
            return []
        base = node.module[len(ROOT) + 1:] if node.module != ROOT else ""
    else:
        here = module.split(".") if module else []
        pkg = here if is_package else here[:-1]
        up = node.level - 1
        pkg = pkg[: len(pkg) - up] if up else pkg
        base = ".".join(pkg + ([node.module] if node.module else []))
    out = []
    for a in node.names:
        sub = f"{base}.{a.name}" if base else a.name
        out.append(sub if sub in MODULES else base)
    return out


def _imports():
    """``(module, target, lineno, function_level, line)`` for every import of a package module."""
    rows = []
    for mod, path in MODULES.items():
        src = path.read_text()
        lines = src.splitlines()
        tree = ast.parse(src)
        top = set(map(id, tree.body))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for target in _resolve(mod, path.name == "__init__.py", node):
                    rows.append((mod, target, node.lineno, id(node) not in top, lines[node.lineno - 1]))
    return rows


IMPORTS = _imports()


def _with_parents(module: str, target: str) -> list[str]:
    """The target and the packages Python initialises to import it from ``module`` (those
    that are not already its own ancestors)."""
    out = [target]
    parts = target.split(".") if target else []
    own = module.split(".")
    for i in range(1, len(parts)):
        pkg = ".".join(parts[:i])
        if own[:i] != parts[:i]:
            out.append(pkg)
    return out


def _layer(module: str) -> int:
    best, best_len = None, -1
    for i, (_, names) in enumerate(LAYERS):
        for n in names:
            match = module == n if n == "" else (module == n or module.startswith(n + "."))
            if match and len(n) > best_len:
                best, best_len = i, len(n)
    assert best is not None, f"module fingerfriction.{module} is in no layer of LAYERS"
    return best


def test_every_module_has_a_layer():
    for mod in MODULES:
        _layer(mod)


def test_no_module_imports_a_higher_layer():
    bad = []
    for mod, target, lineno, _, line in IMPORTS:
        for t in _with_parents(mod, target):
            if t != mod and _layer(t) > _layer(mod):
                bad.append(f"{mod} ({LAYERS[_layer(mod)][0]}) line {lineno} imports {t or ROOT} "
                           f"({LAYERS[_layer(t)][0]}): {line.strip()}")
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for mod, target, *_ in IMPORTS:
        for t in _with_parents(mod, target):
            if t != mod:
                graph[mod].add(t)
    # a package's __init__ importing its own submodules, which Python runs inside that
    # __init__, is not a cycle: drop the submodule -> own package edges
    for mod in graph:
        graph[mod] = {t for t in graph[mod] if not (mod.startswith(t + ".") or (t == "" and mod))}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


@pytest.mark.slow
def test_function_level_imports_say_why():
    bare = [f"{MODULES[mod].relative_to(PKG)}:{lineno}: {line.strip()}"
            for mod, path in MODULES.items()
            for lineno, line in _function_level_import_lines(path)
            if "#" not in line]
    assert not bare, "function-level imports without a one-line reason:\n" + "\n".join(bare)


def _function_level_import_lines(path: Path):
    src = path.read_text()
    lines = src.splitlines()
    tree = ast.parse(src)
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(fn):
                if isinstance(node, (ast.Import, ast.ImportFrom)):
                    yield node.lineno, lines[node.lineno - 1]


def test_no_function_level_import_of_the_package_itself():
    """Function-level imports are for heavy optional libraries, not to hide a cycle; the
    command line alone imports its stages when a command runs (``--help`` stays fast)."""
    hidden = [f"{mod}:{lineno}: {line.strip()}" for mod, _, lineno, fn_level, line in IMPORTS
              if fn_level and mod != "cli" and not mod.startswith("cli.")]
    assert not hidden, "\n".join(hidden)


def _code_lines(fn: ast.FunctionDef) -> int:
    body = fn.body
    has_doc = isinstance(body[0], ast.Expr) and isinstance(getattr(body[0], "value", None), ast.Constant) \
        and isinstance(body[0].value.value, str)
    start = (body[1].lineno if len(body) > 1 else fn.end_lineno) if has_doc else body[0].lineno
    return fn.end_lineno - start + 1


@pytest.mark.slow
def test_long_functions_are_few_and_named():
    long = {}
    for path in MODULES.values():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _code_lines(node) > 80:
                long[f"{path.relative_to(PKG)}:{node.name}"] = _code_lines(node)
    assert len(LONG_FUNCTIONS) <= 5
    assert set(long) <= set(LONG_FUNCTIONS), f"functions over 80 lines of code: {long}"


@pytest.mark.parametrize("mod", sorted(MODULES))
def test_modules_stay_under_600_lines(mod):
    path = MODULES[mod]
    n = len(path.read_text().splitlines())
    if str(path.relative_to(PKG)) in LONG_MODULES:
        return
    assert n <= 600, f"{path.relative_to(PKG)} has {n} lines"


#: Private names imported from another module of the package, each with why.
PRIVATE_IMPORTS = {
    "mechanics/bem.py: _cgkernels": "a private module of bem's own package (its numba kernels), not a name "
                                    "taken out of another module",
}


def test_no_private_name_imported_across_modules():
    found = {}
    for path in MODULES.values():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith(ROOT)):
                for a in node.names:
                    if a.name.startswith("_") and not a.name.startswith("__"):
                        found[f"{path.relative_to(PKG)}: {a.name}"] = node.lineno
    assert set(found) <= set(PRIVATE_IMPORTS), f"private names imported across modules: {found}"
