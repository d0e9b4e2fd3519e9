"""The package's layout figures, printed: the longest modules, every function
over 80 lines, and every function-level import with its reason.

A function's length here is all its lines, ``end_lineno - lineno + 1`` (signature and
docstring included; ``tests/test_layout.py`` counts code lines only, a looser measure).
A function-level import's reason is the comment on its line.

Run: ``.venv/bin/python benchmarks/layout.py [--src src/fingerfriction] [--top 5]``
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "src" / "fingerfriction"


def _functions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


def _qualnames(tree: ast.Module) -> dict[int, str]:
    """``id(node) -> Class.method`` / ``outer.<locals>.inner`` for every function."""
    names: dict[int, str] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                names[id(child)] = prefix + child.name
                visit(child, prefix + child.name + ".<locals>.")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(tree, "")
    return names


def _code_lines(fn: ast.FunctionDef) -> int:
    """Lines from the first statement after the docstring to the end (test_layout's measure)."""
    body = fn.body
    doc = isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
        and isinstance(body[0].value.value, str)
    start = (body[1].lineno if len(body) > 1 else fn.end_lineno) if doc else body[0].lineno
    return fn.end_lineno - start + 1


def measure(src: Path):
    """``(modules, long_functions, function_imports)`` of every ``.py`` file below ``src``."""
    modules, long_fns, fn_imports = [], [], []
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src)
        text = path.read_text()
        lines = text.splitlines()
        modules.append((len(lines), str(rel)))
        tree = ast.parse(text)
        names = _qualnames(tree)
        seen: set[int] = set()
        for fn in _functions(tree):
            n = fn.end_lineno - fn.lineno + 1
            if n > 80:
                long_fns.append((n, _code_lines(fn), f"{rel}:{names[id(fn)]}"))
            for node in ast.walk(fn):
                if isinstance(node, (ast.Import, ast.ImportFrom)) and node.lineno not in seen:
                    seen.add(node.lineno)
                    line = lines[node.lineno - 1]
                    reason = line.split("#", 1)[1].strip() if "#" in line else ""
                    fn_imports.append((f"{rel}:{node.lineno}", names[id(fn)], line.split("#")[0].strip(),
                                       reason))
    return sorted(modules, reverse=True), sorted(long_fns, reverse=True), fn_imports


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, default=ROOT)
    ap.add_argument("--top", type=int, default=5, help="How many of the longest modules to print.")
    args = ap.parse_args()
    modules, long_fns, fn_imports = measure(args.src)
    over = [m for m in modules if m[0] > 600]
    print(f"modules: {len(modules)}; over 600 lines: {len(over)}")
    for n, rel in modules[: max(args.top, len(over))]:
        print(f"  {n:5d}  {rel}")
    print(f"functions over 80 lines: {len(long_fns)} (all lines; "
          f"{sum(c > 80 for _, c, _ in long_fns)} over 80 lines of code, docstring left out)")
    for n, code, name in long_fns:
        print(f"  {n:5d} ({code:3d} of code)  {name}")
    bare = sum(not r for *_, r in fn_imports)
    print(f"function-level imports: {len(fn_imports)} ({bare} without a reason on their line)")
    for where, fn, stmt, reason in fn_imports:
        print(f"  {where} in {fn}: {stmt}  # {reason or 'NO REASON'}")


if __name__ == "__main__":
    main()
