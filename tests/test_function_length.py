"""No function longer than ``MAX_LINES`` without its reason stated where it stands.

A long function is allowed when the line of its ``def`` (or of its first decorator),
or the line just above, holds a ``# long:`` comment saying why (a compiled kernel,
the readable twin kept step-for-step parallel to one). Its length counts from its
first decorator to its last line, docstring included.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("slopewalk", "planner", "bench")
MAX_LINES = 80
MARK = "# long:"


def long_functions(source: str, max_lines: int = MAX_LINES) -> list[tuple[str, int, int]]:
    """(name, first line, length) of each function over ``max_lines`` without a reason."""
    lines = source.splitlines()
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
        length = node.end_lineno - first + 1
        marked = {first - 1, first, node.lineno}  # the line above, the decorator, the def
        if length > max_lines and not any(
            MARK in lines[i - 1] for i in marked if 1 <= i <= len(lines)
        ):
            found.append((node.name, first, length))
    return found


def test_no_long_function_without_a_reason():
    offenders = [
        f"{path.relative_to(ROOT)}:{line} {name} ({length} lines)"
        for folder in FOLDERS
        for path in sorted((ROOT / folder).rglob("*.py"))
        for name, line, length in long_functions(path.read_text())
    ]
    assert not offenders, (
        f"functions over {MAX_LINES} lines: split them, or say why on the def line or the "
        f"line above with '{MARK} ...':\n  " + "\n  ".join(offenders)
    )


def _function(lines: int, comment: str = "") -> str:
    body = "".join(f"    x{i} = {i}\n" for i in range(lines - 1))
    return f"{comment}def f():\n{body}"


def test_the_check_sees_a_long_function_and_its_reason():
    assert long_functions(_function(MAX_LINES)) == []
    assert long_functions(_function(MAX_LINES + 1)) == [("f", 1, MAX_LINES + 1)]
    assert long_functions(_function(MAX_LINES + 1, "# long: a kernel\n")) == []
    assert long_functions("@staticmethod\n" + _function(MAX_LINES)) == [("f", 1, MAX_LINES + 1)]
    nested = "class C:\n" + "".join(
        "    " + line + "\n" for line in _function(MAX_LINES + 1).splitlines()
    )
    assert long_functions(nested) == [("f", 2, MAX_LINES + 1)]
