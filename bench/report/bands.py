"""``bands.csv`` and ``bands.md``: the envelope's boundaries under the spec's unknowns.

The rows are ``experiments.envelope.bands.run_bands``'s: per family and boundary, the
nominal spec's boundary and each estimated value's at its low and high end. The band of a
boundary is the min–max of all of them; the value that *moves it most* is the one whose
low, nominal and high boundaries span the most grid cells. ``boundaries.md`` quotes the
bands from ``bands.csv`` when it lies beside it (``band_lines``).
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from slopewalk.bench.files import atomic_path
from slopewalk.planner.gait_search import min_knee_flexion, swing_clearance
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.verdict import SLIP_DISTANCE

CSV_NAME = "bands.csv"
MD_NAME = "bands.md"
COLUMNS = ("family", "boundary", "key", "end", "value", "low", "high", "unit", "index", "at",
           "edge", "nominal_cell_margin_mm", "searched")  # fmt: skip
# boundary: (what it is, unit of its value)
BOUNDARIES = {
    "flat": ("fastest flat step time inside", " s"),
    "up": ("steepest uphill slope inside at t_c = 1 s", "°"),
    "down": ("steepest downhill slope inside at t_c = 1 s", "°"),
}


def admissibility(spec: RobotSpec, friction: float = 1.0) -> str:
    """The GA's admissibility constraints with the spec's numbers, as a sentence's list."""
    return (
        f"the knee bent at least {min_knee_flexion(spec):.3f} rad from straight (the servo's "
        f"compliance band, stall torque / kp), the swing lift at least "
        f"{swing_clearance(spec) * 1e3:.1f} mm (hip width · sin 5°, the simulator's tip "
        f"angle), the planned friction ratio |F_t|/F_n at most μ = {friction:g}, and the planned "
        f"slide of a loaded foot at most {SLIP_DISTANCE * 1e3:g} mm (the simulator's slip "
        "threshold), besides every pitch joint within its limits (planner/gait_search.py)"
    )


def write_csv(rows: list[dict], path: Path) -> Path:
    """``bands.csv``: one row per family × boundary × (nominal | value × end)."""
    out = io.StringIO()
    writer = csv.DictWriter(out, COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row.get(k)) for k in COLUMNS})
    with atomic_path(path) as tmp:
        tmp.write_text(out.getvalue())
    return path


def _cell(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return f"{value:.10g}" if isinstance(value, float) else str(value)


def read_csv(path: Path) -> list[dict]:
    """The rows of a ``bands.csv``: ``at`` a float or None (no cell inside), ``index`` an int."""
    rows = []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            row["index"] = int(row["index"])
            row["at"] = float(row["at"]) if row["at"] else None
            row["edge"] = row["edge"] == "True"
            row["nominal_cell_margin_mm"] = float(row["nominal_cell_margin_mm"])
            rows.append(row)
    return rows


def _show(at, boundary: str, edge: bool = False) -> str:
    if at is None:
        return "none inside"
    return f"{at:g}{BOUNDARIES[boundary][1]}" + (" (grid edge)" if edge else "")


def summaries(rows: list[dict]) -> list[dict]:
    """Per family × boundary: nominal, band (lo, hi), and the values that move it most.

    The band's ends are grid values (None: no cell inside for some spec). The values that
    move it most are those whose (low, nominal, high) boundaries span the most grid cells
    (``span``), ordered by how far their two ends move the largest margin at the nominal
    boundary's cell (``spread`` [mm], per key); when none moves the boundary a cell,
    ``movers`` is empty and ``closest`` names the value of largest spread.
    """
    out = []
    groups: dict[tuple[str, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["family"], row["boundary"]), []).append(row)
    for (family, boundary), group in groups.items():
        nominal = next(r for r in group if r["end"] == "nominal")
        ends: dict[str, list[dict]] = {}
        for r in group:
            if r["end"] != "nominal":
                ends.setdefault(r["key"], []).append(r)
        span, spread = {}, {}
        for key, pair in ends.items():
            indices = [r["index"] for r in [*pair, nominal]]
            span[key] = max(indices) - min(indices)
            margins = [r["nominal_cell_margin_mm"] for r in [*pair, nominal]]
            spread[key] = max(margins) - min(margins)
        most = max(span.values(), default=0)
        movers = sorted((k for k, v in span.items() if v == most and most > 0),
                        key=lambda k: -spread[k])  # fmt: skip
        ats = [r["at"] for r in group]
        values = [a for a in ats if a is not None]
        out.append({
            "family": family,
            "boundary": boundary,
            "nominal": nominal,
            "band": (None if None in ats else min(values), max(values) if values else None),
            "movers": movers,
            "span": most,
            "spread": spread,
            "closest": max(spread, key=lambda k: spread[k]) if spread else None,
        })  # fmt: skip
    return out


def _unit(row: dict) -> str:
    """The unit of a row's value after a space; nothing for a value without one (a ratio)."""
    return f" {row['unit']}" if row["unit"] else ""


def picks(
    rows: list[dict], walk: tuple[str, ...] = ()
) -> list[tuple[str, str, str, str, float, int]]:
    """The boundary cells worth walking in MuJoCo, per family × boundary: the nominal spec's
    and, for the value that moves the boundary most (or, when none moves it, moves its
    margin most) and then for each key of ``walk`` (``--walk``: values the analytic
    boundaries may not see, like the floor's contact), each end's; (family, boundary, key,
    end, value, index), no cell when none is inside."""
    out = []
    for s in summaries(rows):
        top = s["movers"][0] if s["movers"] else s["closest"]
        keys = [top, *(k for k in walk if k != top)]
        chosen = [s["nominal"]] + [
            r for key in keys for r in rows
            if r["family"] == s["family"] and r["boundary"] == s["boundary"]
            and r["key"] == key and r["end"] != "nominal"
        ]  # fmt: skip
        for r in chosen:
            if r["index"] >= 0:
                value = float(r["value"]) if r["value"] not in (None, "") else math.nan
                out.append((r["family"], r["boundary"], r["key"], r["end"], value, r["index"]))
    return out


def played_lines(played: list[dict]) -> list[str]:
    """bands.md's table of the boundary gaits walked in MuJoCo (``play_boundaries``'s rows)."""
    modes = list(played[0]["verdicts"]) if played else []
    lines = [
        "The boundary gaits walked in MuJoCo (the envelope's own cell, `run_cell`: both "
        "searches, the max-margin gait re-planned at 1 ms and played open loop in every "
        "actuator mode, with the spec as changed; its margin pools both searches, so it may "
        "exceed the table's), for the value that moves each boundary most (or its margin, "
        "when none moves it a cell) and for those `--walk` names, at each end; the balance "
        "verdict, and in brackets the strict walk "
        "verdict where it differs (`walked` needs the plan walked within the servo's stall "
        "torque, `docs/verdicts.md`):",
        "",
        "| family | boundary | spec | cell | margin | " + " | ".join(modes) + " |",
        "|---|---|---|---|---|" + "---|" * len(modes),
    ]
    for p in played:
        spec = "nominal" if p["key"] == "nominal" else f"{p['key']} = {p['value']:g}"
        cell = f"{p['step_time']:g} s, {p['slope_deg']:g}°"
        verdicts = " | ".join(p["verdicts"][m] for m in modes)
        lines.append(
            f"| {p['family']} | {p['boundary']} | {spec} | {cell} | "
            f"{p['margin_mm']:+.1f} mm | {verdicts} |"
        )
    return lines


def convergence_lines(checked: list[dict], factor: int) -> list[str]:
    """bands.md's paragraph on the GA budget: the walked boundary cells and the first cell
    beyond each (``converge_boundaries``'s rows), searched with ``factor`` × the generations."""
    flips = [c for c in checked if c["inside"] != c["inside_big"]]
    change = max(checked, key=lambda c: abs(c["margin_big_mm"] - c["margin_mm"]))
    nearest = min(checked, key=lambda c: abs(c["margin_mm"]))
    unit = BOUNDARIES[change["boundary"]][1]
    return [
        f"Convergence: the {len(checked)} cells of the walked boundaries and the first cell "
        f"beyond each, searched again with {factor} × the generations: {len(flips)} inside / "
        "outside verdicts change; the largest margin change is "
        f"{change['margin_big_mm'] - change['margin_mm']:+.2f} mm ({change['boundary']} "
        f"{change['at']:g}{unit}, {change['key']} {change['end']}); the margin nearest 0 is "
        f"{nearest['margin_mm']:+.2f} mm ({nearest['margin_big_mm']:+.2f} mm at {factor} ×; "
        f"{nearest['boundary']} {nearest['at']:g}{BOUNDARIES[nearest['boundary']][1]}, "
        f"{nearest['key']} {nearest['end']}).",
    ]


def _band_text(s: dict) -> str:
    lo, hi = s["band"]
    unit = BOUNDARIES[s["boundary"]][1]
    if lo is None and hi is None:
        return "none inside for every spec"
    low = "none inside" if lo is None else f"{lo:g}"
    return f"[{low}, {hi:g}]{unit}"


def _mover_text(s: dict, rows: list[dict]) -> str:
    def ends(key):
        return {r["end"]: r for r in rows if r["family"] == s["family"]
                and r["boundary"] == s["boundary"] and r["key"] == key}  # fmt: skip

    nominal = s["nominal"]["nominal_cell_margin_mm"]
    if not s["movers"]:
        if s["closest"] is None:
            return "no value moves it"
        e = ends(s["closest"])
        return (
            f"no value moves it a grid cell; its margin there ({nominal:+.1f} mm) moves most "
            f"with {s['closest']} ({e['low']['nominal_cell_margin_mm']:+.1f} mm at "
            f"{float(e['low']['value']):g}{_unit(e['low'])}, "
            f"{e['high']['nominal_cell_margin_mm']:+.1f} mm at {float(e['high']['value']):g}"
            f"{_unit(e['high'])})"
        )
    parts = []
    for key in s["movers"]:
        e = ends(key)
        low, high = e["low"], e["high"]
        parts.append(
            f"{key} ({_show(low['at'], s['boundary'])} at {float(low['value']):g}"
            f"{_unit(low)}, {_show(high['at'], s['boundary'])} at "
            f"{float(high['value']):g}{_unit(high)}; margin at the nominal boundary "
            f"{low['nominal_cell_margin_mm']:+.1f} / {nominal:+.1f} / "
            f"{high['nominal_cell_margin_mm']:+.1f} mm)"
        )
    text = "moves most with " + parts[0]
    if len(parts) > 1:
        text += f"; as far, by less margin: {'; '.join(parts[1:])}"
    return text


def band_lines(rows: list[dict]) -> list[str]:
    """One line per family × boundary: "paper, fastest flat step time inside: 0.7 s, band
    [0.6, 0.8] s over the spec's unknowns; moves most with ..." (boundaries.md's)."""
    return [
        f"- {s['family']}, {BOUNDARIES[s['boundary']][0]}: "
        f"{_show(s['nominal']['at'], s['boundary'], s['nominal']['edge'])}, band "
        f"{_band_text(s)} over the spec's unknowns; {_mover_text(s, rows)}"
        for s in summaries(rows)
    ]


def markdown(rows: list[dict], *, source: str, robot: str, spec: RobotSpec, search, wall_s: float,
             workers: int, played: list[dict] | None = None, checked: list[dict] | None = None,
             factor: int = 4) -> str:  # fmt: skip
    """``bands.md``: the summary per boundary, then every value's row; with ``played``, the
    boundary gaits walked in MuJoCo (``played_lines``)."""
    keys = {r["key"] for r in rows if r["end"] != "nominal"}
    lines = [
        "# The envelope's boundaries under the robot's unknowns",
        "",
        f"Written by `slopewalk bands` from the envelope file {source} and the `[uncertain]` "
        f"table of the robot spec {robot} ({len(keys)} estimated values), in "
        f"{wall_s / 60:.1f} min on {workers} workers.",
        "",
        "Each boundary of `boundaries.md` is searched again with the spec changed in **one** "
        "value at a time, set to the low and then the high end of its range, every other "
        "value at the spec's (no corners or combinations of values). *Inside*: the "
        "envelope's max-margin GA search of the cell with the envelope's settings (population "
        f"{search.population}, {search.generations} generations, seed {search.seed}; its best "
        "gait re-planned at 1 ms) finds a gait whose ZMP is inside the support polygon at "
        "every instant. The envelope also pools its min-work search's individuals, left out "
        "here to halve the cost, so a cell inside here is inside there (same code and spec), "
        f"not always the reverse. The GA admits only gaits with {admissibility(spec)}; a "
        "boundary may be set by one of these rather than by the ZMP. The boundaries are "
        "analytic; MuJoCo walks only the boundary gaits of the first table below.",
        "",
        "A boundary is searched on the envelope's own grid, from the nominal spec's boundary "
        "outwards while the cell is inside, else inwards (the last inside cell before the "
        "first outside one, from the easy end: slow steps, level ground), so a band is only "
        "as fine as the grid, and an inside cell beyond the first outside one is not looked "
        "for. The band is the min–max over the nominal and every value's two ends; the value "
        "that moves a boundary most spans the most grid cells, ties ordered by how far it "
        "moves the margin at the nominal boundary's cell. `bands.csv` holds every row "
        "with the largest margin of each cell searched (`searched`): a margin within a few "
        "tenths of a millimetre of 0 is a verdict a bigger GA budget might flip "
        "(`convergence.md` checks the envelope's budget).",
        "",
        *band_lines(rows),
        "",
        *(played_lines(played) + [""] if played else []),
        *(convergence_lines(checked, factor) + [""] if checked else []),
        "| family | boundary | value | range | at low | nominal | at high | margin at the "
        "nominal boundary, low / nominal / high |",
        "|---|---|---|---|---|---|---|---|",
    ]
    nominal = {(r["family"], r["boundary"]): r for r in rows if r["end"] == "nominal"}
    by_key: dict[tuple, dict] = {}
    for r in rows:
        if r["end"] != "nominal":
            by_key.setdefault((r["family"], r["boundary"], r["key"]), {})[r["end"]] = r
    for (family, boundary, key), ends in by_key.items():
        low, high = ends["low"], ends["high"]
        n = nominal[family, boundary]
        mark = {e: " **" if r["index"] != n["index"] else "" for e, r in ends.items()}
        lines.append(
            f"| {family} | {boundary} | {key} | [{float(low['low']):g}, {float(low['high']):g}]"
            f"{_unit(low)} | {_show(low['at'], boundary, low['edge'])}{mark['low']} | "
            f"{_show(n['at'], boundary, n['edge'])} | "
            f"{_show(high['at'], boundary, high['edge'])}{mark['high']} | "
            f"{low['nominal_cell_margin_mm']:+.1f} / {n['nominal_cell_margin_mm']:+.1f} / "
            f"{high['nominal_cell_margin_mm']:+.1f} mm |"
        )
    lines += [
        "",
        "**: this end moves the boundary. The margin column: the largest margin the search "
        "finds at the nominal spec's boundary cell (positive: inside), with the value at its "
        "low end, the spec's, and its high end; it shows how near a value comes to moving "
        "the boundary when it does not move it a grid cell.",
    ]
    return "\n".join(lines) + "\n"


def write_markdown(text: str, path: Path) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path
