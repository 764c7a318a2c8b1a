"""Where a kernel entry's cold compile goes, per compiled function (issue 24).

Usage: NUMBA_CACHE_DIR=$(mktemp -d) python tools/compile_profile.py ENTRY [--json FILE]

Compiles ``warm.compile_entry(ENTRY)`` in this process on the (empty) cache given and
records numba's events (``numba.core.event``): each function's compile
("numba:compile"), its compiler passes ("numba:run_pass") and the time spent in LLVM
("numba:llvm_lock": every llvmlite call holds that lock). Times are exclusive: a
callee's compile, which numba runs inside its caller's type inference, counts for the
callee alone. Per function: type inference, numba's inlining passes, lowering (numba's
Python making LLVM IR), LLVM (optimising and emitting code, also the callers' linked-in
copies of their callees, which numba optimises again in every caller), and the rest
(the other passes, the cache's save). Prints a table, CPU seconds of the process.
"""

from __future__ import annotations

import json
import sys
import time
from collections import defaultdict

from numba.core import event

_INFER = {"nopython_type_inference", "partial_type_inference"}
_INLINE = {"inline_inlinables", "inline_closure_likes", "InlineOverloads", "inline_closure_call"}
_LOWER = {"native_lowering", "native_parfor_lowering"}


def _category(pass_name: str) -> str:
    if pass_name in _INFER:
        return "infer"
    if pass_name in _INLINE:
        return "inline"
    if pass_name in _LOWER:
        return "lower"
    return "passes"


class _Profile(event.Listener):
    """A stack of events; each one's exclusive CPU time to (function, category)."""

    def __init__(self):
        self.stack: list[list] = []  # [kind, function, category, start, children]
        self.table: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
        self.compiles: dict[str, int] = defaultdict(int)

    def _function(self) -> str:
        for kind, function, *_ in reversed(self.stack):
            if kind in ("numba:compile", "numba:run_pass"):
                return function
        return "(outside)"

    def on_start(self, ev):
        if ev.kind == "numba:compile":
            py = ev.data["dispatcher"].py_func
            function, category = f"{py.__module__.rsplit('.', 1)[-1]}.{py.__qualname__}", "other"
            self.compiles[function] += 1
        elif ev.kind == "numba:run_pass":
            function = f"{ev.data['module'].rsplit('.', 1)[-1]}.{ev.data['qualname']}"
            category = _category(ev.data["name"].split(" ")[0])
        elif ev.kind == "numba:llvm_lock":
            function, category = self._function(), "llvm"
        else:
            return
        self.stack.append([ev.kind, function, category, time.process_time(), 0.0])

    def on_end(self, ev):
        if ev.kind not in ("numba:compile", "numba:run_pass", "numba:llvm_lock"):
            return
        kind, function, category, start, children = self.stack.pop()
        assert kind == ev.kind, (kind, ev.kind)
        spent = time.process_time() - start
        self.table[function][category] += spent - children
        if self.stack:
            self.stack[-1][4] += spent


def main() -> None:
    entry = sys.argv[1]
    start = time.process_time()
    import slopewalk.planner.kernel  # noqa: F401  (numba configured)

    imported = time.process_time()
    profile = _Profile()
    event.register("numba:compile", profile)
    event.register("numba:run_pass", profile)
    event.register("numba:llvm_lock", profile)
    from slopewalk.planner.kernel.warm import compile_entry

    compile_entry(entry)
    total = time.process_time() - imported
    columns = ("infer", "inline", "lower", "llvm", "passes", "other")
    rows = sorted(profile.table.items(), key=lambda kv: -sum(kv[1].values()))
    print(f"{entry}: {total:.2f} s CPU after imports ({imported - start:.2f} s imports)")
    print(f"{'function':34} {'n':>2} {'total':>6} " + " ".join(f"{c:>6}" for c in columns))
    sums = defaultdict(float)
    for function, parts in rows:
        for c in columns:
            sums[c] += parts[c]
        print(
            f"{function:34} {profile.compiles[function]:>2} {sum(parts.values()):6.2f} "
            + " ".join(f"{parts[c]:6.2f}" for c in columns)
        )
    print(
        f"{'(sum)':34} {'':>2} {sum(sums.values()):6.2f} "
        + " ".join(f"{sums[c]:6.2f}" for c in columns)
    )
    if "--json" in sys.argv:
        with open(sys.argv[sys.argv.index("--json") + 1], "w") as f:
            json.dump({"entry": entry, "total": total, "table": profile.table}, f, indent=1)


if __name__ == "__main__":
    main()
