"""No code outside the variant registry (``fit/variants.py``) branches on a model variant's
name: a new variant plugs into the registry and every stage (fit, validation, prediction,
report) takes it from there.

Scanned with ``ast`` in every module of the package: a comparison with a variant's name
(``m == "load"``, ``m in ("paper", ...)``, a ``match`` case), a variant's name as a fallback
(``d.get("model", "paper")``, ``x or "load"``, a parameter's default) and a variant picked by
its literal name (``get("paper")``, ``fits["paper"]``). A variant's own fitting module may
label what it raises with its own name (its parameters' defaults): :data:`OWN_NAME`."""

from __future__ import annotations

import ast
from pathlib import Path

from fingerfriction.fit.variants import MODELS

PKG = Path(__file__).resolve().parents[1] / "src" / "fingerfriction"
REGISTRY = "fit/variants.py"

#: Modules that implement one variant's fit, with the names whose use as a parameter's
#: default (the label of the flags they raise) is theirs.
OWN_NAME = {
    "fit/load.py": {"load"},
    "fit/load_results.py": {"load"},
    "fit/mu.py": {"load"},
}


def _is_name(node) -> bool:
    return isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in MODELS


def _names_in(node) -> bool:
    if _is_name(node):
        return True
    return isinstance(node, (ast.Tuple, ast.List, ast.Set)) and any(_is_name(e) for e in node.elts)


def _findings(rel: str, tree: ast.AST) -> list[tuple[int, str]]:
    out = []
    own = OWN_NAME.get(rel, set())
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare) and any(_names_in(n) for n in (node.left, *node.comparators)):
            out.append((node.lineno, "compares with a variant's name"))
        elif isinstance(node, ast.match_case):
            pats = [p for p in ast.walk(node.pattern) if isinstance(p, ast.MatchValue) and _is_name(p.value)]
            if pats:
                out.append((pats[0].lineno, "matches a variant's name"))
        elif isinstance(node, ast.BoolOp) and isinstance(node.op, ast.Or) and any(map(_is_name, node.values)):
            out.append((node.lineno, "falls back to a variant's name (or)"))
        elif isinstance(node, ast.Call):
            func = node.func
            fname = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if fname == "get" and len(node.args) >= 2 and _is_name(node.args[1]):
                out.append((node.lineno, "falls back to a variant's name (.get default)"))
            elif fname == "get" and node.args and _is_name(node.args[0]):
                out.append((node.lineno, "picks a variant by its name"))
        elif isinstance(node, ast.Subscript) and _is_name(node.slice):
            out.append((node.lineno, "picks a variant's entry by its name"))
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            for d in [*a.defaults, *[k for k in a.kw_defaults if k is not None]]:
                if _is_name(d) and d.value not in own:
                    out.append((d.lineno, "defaults to a variant's name"))
    return out


def test_the_scan_finds_each_kind_of_branch():
    src = '''
def f(m="load"):
    if m == "paper" or m in ("interlock",):
        pass
    x = d.get("model", "paper") or "load"
    match m:
        case "pressure":
            pass
    return get("paper"), fits["load"]
'''
    kinds = sorted({why for _, why in _findings("x.py", ast.parse(src))})
    assert kinds == sorted({"defaults to a variant's name", "compares with a variant's name",
                            "falls back to a variant's name (.get default)",
                            "falls back to a variant's name (or)", "matches a variant's name",
                            "picks a variant by its name", "picks a variant's entry by its name"})
    # text that names a variant without choosing by it is not a branch
    assert _findings("x.py", ast.parse('flag("paper", "message")\nname = "load"')) == []


def test_no_branch_on_a_variant_name_outside_the_registry():
    bad = []
    for path in sorted(PKG.rglob("*.py")):
        rel = str(path.relative_to(PKG))
        if rel == REGISTRY:
            continue
        text = path.read_text()
        lines = text.splitlines()
        for lineno, why in _findings(rel, ast.parse(text)):
            bad.append(f"{rel}:{lineno}: {why}: {lines[lineno - 1].strip()}")
    assert not bad, "ask the variant (fingerfriction.fit.variants.get) instead:\n" + "\n".join(bad)
