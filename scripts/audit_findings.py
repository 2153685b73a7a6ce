#!/usr/bin/env python3
"""Audit findings.csv by a second path: recompute every finding from the experiments' CSVs with
pandas, by the rules of docs/verdicts.md, and compare with the findings.csv the harness wrote.

    scripts/audit_findings.py REPORTS_DIR [--verbose]

Exit status 0 when every row of REPORTS_DIR/findings.csv is the one recomputed here (the same
conditions in the same order; the same best method and setting, means, runner-up, difference,
identical and not-ranked methods, verdict word, cost and cheapest choice; bootstrap intervals
within a Monte-Carlo tolerance of this script's own), else 1 with every difference listed.
This is deliberately a different language and library from the Rust code that writes the
findings (crates/harness/src/experiments/findings.rs and rules/): the two must agree.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

# --- the rules (docs/verdicts.md) -------------------------------------------------------------

F1_MARGIN = 0.005  # F1 and pixel F1
PSNR_MARGIN = 0.1  # dB, BD-PSNR included
TIME_MARGIN = 0.05  # relative
MIN_VIEWS = 5  # no interval from fewer
RESAMPLES = 10_000
JACCARD = 0.999  # a method claiming exactness below this on an unperturbed cell: wrong answers
SAME = 1e-12  # two scores this close are the same score
LOD_BUDGETS = [0.01, 0.02, 0.05, 0.1, 0.2, 0.3]
BD_ANCHOR = "random"
IDENTICAL_PSNR = 100.0
OOC_SUFFIX = "-build-ooc"
SCALE_SIZE = 10_000_000
IN_SAMPLE = "tuning data: in-sample"
OUT_OF_SAMPLE = "evaluation: settings tuned on the tuning data"
POOLED = "evaluation datasets pooled"

# The built-in datasets' roles, for results whose metadata does not record them.
EVALUATION = {"elephant-50000", "camel-50000", "triceratops-50000", "mannequin-50000"}
TUNING = {
    "bunny", "bunny-69451", "dragon-871414", "sphere-20000", "sphere-plane-24000",
    "torus-22321", "vase-7171", "armadillo-200004", "bunny-noise-0.5", "bunny-outliers-0.05",
    "bunny-scan-4", "dragon-scan-4", "bunny-mobile", "dragon-mobile",
}


def role(name: str, recorded: dict) -> str:
    if name in recorded:
        return recorded[name]
    if name in EVALUATION:
        return "evaluation"
    return "tuning" if name in TUNING else "own"


def metadata(folder: Path) -> dict:
    path = folder / "metadata.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def bootstrap(values: list[float], seed: int = 12345) -> tuple[float, tuple[float, float] | None]:
    """The mean and its percentile bootstrap 95 % interval (none below MIN_VIEWS values)."""
    v = np.asarray(values, dtype=float)
    mean = float(v.mean())
    if len(v) < MIN_VIEWS:
        return mean, None
    rng = np.random.default_rng(seed)
    means = np.sort(v[rng.integers(0, len(v), size=(RESAMPLES, len(v)))].mean(axis=1))
    at = lambda q: float(means[int(round(q * (RESAMPLES - 1)))])  # noqa: E731
    return mean, (at(0.025), at(0.975))


def word(lo: float, hi: float, center: float, margin: float) -> str:
    if lo > center + margin:
        return "wins"
    if lo >= center - margin and hi <= center + margin:
        return "equivalent"
    return "no clear winner"


def with_setting(method: str, setting: str) -> str:
    pairs = [p for p in str(setting).split(";") if p and not p.startswith("seed=")]
    return f"{method} {' '.join(pairs)}" if pairs else method


def median(values) -> float:
    v = [x for x in values if not math.isnan(x)]
    return float(np.median(v)) if v else math.nan


def text(x) -> str:
    return "" if x is None or (isinstance(x, float) and math.isnan(x)) else str(x)


# --- the verdict over a condition's cells ---------------------------------------------------------


def verdict(cells: pd.DataFrame, margin: float, tolerance: float | None, identical: bool):
    """cells: method, setting, key, value, cost, answer (None: no fingerprint)."""
    cells = cells[np.isfinite(cells["value"].astype(float))]
    if cells.empty:
        return None
    groups: dict[tuple[str, str], dict[str, tuple[float, float, str | None]]] = {}
    for (m, s, k), g in cells.groupby(["method", "setting", "key"], sort=False):
        answer = g["answer"].iloc[0]
        groups.setdefault((m, s), {})[k] = (g["value"].mean(), g["cost"].mean(), answer)
    every = set().union(*[set(v) for v in groups.values()])
    if any(len(v) == len(every) for v in groups.values()):
        keys = sorted(every)
    else:
        most = None
        for gid in sorted(groups):
            if most is None or len(groups[gid]) > len(groups[most]):
                most = gid
        keys = sorted(groups[most])
    complete = {gid: v for gid, v in sorted(groups.items()) if all(k in v for k in keys)}
    apart: dict[str, int] = {}
    for (m, _), v in sorted(groups.items()):
        if not any(cm == m for cm, _ in complete):
            apart[m] = max(apart.get(m, 0), sum(1 for k in v if k in keys))
    mean = lambda v: sum(v[k][0] for k in keys) / len(keys)  # noqa: E731
    cost = lambda v: median([v[k][1] for k in keys])  # noqa: E731

    def order(a):  # (mean, cost) -> sort key: higher mean, then known and lower cost
        m, c = a
        return (-m, math.isnan(c), 0.0 if math.isnan(c) else c)

    best: dict[str, tuple[str, float, float]] = {}
    for (m, s), v in complete.items():
        mc = (mean(v), cost(v))
        if m not in best or order(mc) < order((best[m][1], best[m][2])):
            best[m] = (s, mc[0], mc[1])
    if not best:
        return None
    ranked = sorted(best.items(), key=lambda kv: (order((kv[1][1], kv[1][2])), kv[0]))
    wm, (ws, wv, _) = ranked[0]
    winner = complete[(wm, ws)]
    value = bootstrap([winner[k][0] for k in keys])
    ident, runner = [], None
    for rm, (rs, rv, _) in ranked[1:]:
        other = complete[(rm, rs)]
        same = all(
            (winner[k][2] == other[k][2]) if (winner[k][2] and other[k][2])
            else abs(winner[k][0] - other[k][0]) <= SAME
            for k in keys
        )
        if identical and same:
            ident.append(with_setting(rm, rs))
            continue
        diff = bootstrap([winner[k][0] - other[k][0] for k in keys])
        runner = (rm, rs, rv, diff)
        break
    cheapest = None
    if tolerance is not None:
        options = [
            (m, s, mean(v), cost(v)) for (m, s), v in complete.items()
            if mean(v) >= wv - tolerance and not math.isnan(cost(v))
        ]
        if options:
            cheapest = min(options, key=lambda o: (o[3], -o[2]))
    return {
        "method": wm, "setting": ws, "value": value, "n": len(keys), "cost": cost(winner),
        "identical": "; ".join(ident), "runner": runner, "cheapest": cheapest,
        "apart": [f"{m}: {n} of {len(keys)} cells" for m, n in apart.items()],
        "margin": margin,
    }


def finding(experiment, condition, v, quick, notes=()):
    value, interval = v["value"]
    row = {
        "experiment": experiment, "condition": condition, "method": v["method"],
        "setting": v["setting"], "value": value, "low": interval[0] if interval else None,
        "high": interval[1] if interval else None, "n_views": v["n"],
        "indicative": quick or v["n"] < MIN_VIEWS, "identical": v["identical"],
        "not_ranked": "; ".join(list(notes) + v["apart"]), "cost": v["cost"],
        "runner_up": "", "runner_up_value": None, "difference": None,
        "difference_low": None, "difference_high": None, "verdict": "only method",
        "cheapest": "", "cheapest_value": None, "cheapest_cost": None,
    }
    if v["runner"]:
        rm, rs, rv, (d, di) = v["runner"]
        row.update(runner_up=with_setting(rm, rs), runner_up_value=rv, difference=d,
                   difference_low=di[0] if di else None, difference_high=di[1] if di else None,
                   verdict=word(di[0], di[1], 0.0, v["margin"]) if di else "indicative")
    if v["cheapest"]:
        m, s, cv, cc = v["cheapest"]
        row.update(cheapest=with_setting(m, s), cheapest_value=cv, cheapest_cost=cc)
    return row


# --- wrong answers ------------------------------------------------------------------------------


def failing(frame: pd.DataFrame, name: str, jaccard: str) -> dict[str, float]:
    frame = frame[np.isfinite(frame[jaccard].astype(float))]
    worst = frame.groupby(name)[jaccard].min()
    return {k: float(v) for k, v in worst.items() if v < JACCARD}


def wrong_hulls(folder: Path) -> dict[str, float]:
    path = folder / "results.csv"
    if not path.is_file():
        return {}
    rows = pd.read_csv(path)
    rows = rows[(rows["status"] == "ok") & (rows["perturb"] == 0.0)]
    return failing(rows, "hull", "jaccard_vs_exact")


def wrong_peers(folder: Path) -> dict[str, float]:
    path = folder / "peers.csv"
    if not path.is_file():
        return {}
    rows = pd.read_csv(path)
    if "claims_exact" not in rows:
        return {}
    rows = rows[rows["claims_exact"].astype(str).str.lower() == "true"]
    return failing(rows, "peer", "jaccard")


def notes(wrong: dict[str, float], methods) -> list[str]:
    return [f"{m}: wrong answers (worst Jaccard {wrong[m]:.3f})" for m in sorted(set(methods)) if m in wrong]


# --- visibility ----------------------------------------------------------------------------------


def is_auto(params: str) -> bool:
    return any(p.split("=", 1)[1] == "auto" for p in str(params).split(";") if "=" in p)


def tune(obs: pd.DataFrame, tuning: set[str]) -> dict[str, str]:
    """obs: dataset, family, params, f1 of ok rows. Each family's tuned setting."""
    obs = obs[obs["dataset"].isin(tuning) & np.isfinite(obs["f1"].astype(float))]
    out = {}
    for family, g in obs.groupby("family"):
        datasets = set(g["dataset"])
        per = g.groupby(["params", "dataset"])["f1"].mean()
        scores = {}
        for params, pg in per.groupby(level=0):
            if len(pg) == len(datasets):
                scores[params] = float(pg.mean())
        fixed = {p: t for p, t in scores.items() if not is_auto(p)}
        has_fixed = any(not is_auto(p) for p in g["params"].unique())
        candidates = fixed if has_fixed else scores
        chosen = None
        for p in sorted(candidates):
            if chosen is None or candidates[p] > candidates[chosen]:
                chosen = p
        if chosen is not None:
            out[family] = chosen
    return out


def visibility_findings(folder: Path, quick: bool) -> list[dict]:
    rows = pd.read_csv(folder / "results.csv", keep_default_na=False, na_values=["NaN"])
    rows["f1"] = rows["f1"].astype(float)
    if "made_for" not in rows:
        rows["made_for"] = "points"
    if "visible_sha256" not in rows:
        rows["visible_sha256"] = ""
    recorded = metadata(folder).get("parameters", {}).get("dataset_roles", {}) or {}
    names = list(dict.fromkeys(rows["dataset"]))
    roles = {d: role(d, recorded) for d in names}
    tuning = {d for d, r in roles.items() if r == "tuning"}
    ok = rows[rows["status"] == "ok"]
    wrong = wrong_peers(folder)

    def condition_rows(frame, value, answer, scope, untuned, tuned):
        conditions = []
        for d in dict.fromkeys(frame["dataset"]):
            g = frame[frame["dataset"] == d]
            conditions.append((d, pd.DataFrame({
                "method": g["family"], "setting": g["params"], "key": g["view"].astype(str),
                "value": value(g), "cost": g["cost"], "answer": answer(g)})))
        evaluation = [(d, c) for d, c in conditions if roles.get(d) == "evaluation"]
        if len(evaluation) >= 2 and tuned:
            pooled = pd.concat([c.assign(key=d + " " + c["key"]) for d, c in evaluation])
            conditions.insert(0, (f"{POOLED}: {', '.join(d for d, _ in evaluation)}", pooled))
        out = []
        for d, cells in conditions:
            kept = cells[~cells["method"].isin(wrong)]
            oracle = [f for f in dict.fromkeys(kept["method"]) if f not in tuned]
            r = "evaluation" if d.startswith(POOLED) else roles.get(d, "own")
            how = untuned if not tuned else {
                "tuning": IN_SAMPLE, "evaluation": OUT_OF_SAMPLE,
            }.get(r, "own data: settings tuned on the tuning data")
            label = (f"{d} ({scope}{how})" if not oracle or not tuned
                     else f"{d} ({scope}{how}; oracle for {', '.join(oracle)})")
            out.append((label, cells[~cells["method"].isin(wrong)], notes(wrong, cells["method"])))
        return out

    found = []
    points = ok[ok["made_for"] == "points"].copy()
    tuned = tune(rows[rows["status"] == "ok"][["dataset", "family", "params", "f1"]], tuning)
    stands = points.apply(lambda r: tuned.get(r["family"], r["params"]) == r["params"], axis=1)
    points = points[stands].assign(cost=points["seconds"])
    per_point = []
    for label, cells, ns in condition_rows(
        points, lambda g: g["f1"], lambda g: [a if a else None for a in g["visible_sha256"]], "",
        "oracle: best setting on these data, no tuning data in the run", tuned,
    ):
        v = verdict(cells, F1_MARGIN, 0.01, True)
        if v:
            per_point.append(finding("visibility", label, v, quick, ns))
    per_pixel = []
    pixels_path = folder / "pixels.csv"
    if pixels_path.is_file():
        px = pd.read_csv(pixels_path, keep_default_na=False, na_values=["NaN"])
        if "made_for" not in px:
            px["made_for"] = "pixels"
        px = px[px["made_for"] == "pixels"].copy()
        p, c = px["pixel_precision"].astype(float), px["mesh_coverage"].astype(float)
        px["f1"] = np.where(p + c > 0, 2 * p * c / (p + c).where(p + c > 0, 1.0), 0.0)
        px_names = list(dict.fromkeys(px["dataset"]))
        px_roles = {d: role(d, recorded) for d in px_names}
        px_tuned = tune(px[["dataset", "family", "params", "f1"]],
                        {d for d, r in px_roles.items() if r == "tuning"})
        seconds = ok.set_index(["dataset", "view", "family", "params"])["seconds"]
        seconds = seconds[~seconds.index.duplicated(keep="last")]
        px["cost"] = [seconds.get((r.dataset, r.view, r.family, r.params), math.nan)
                      for r in px.itertuples()]
        px = px[px.apply(lambda r: px_tuned.get(r["family"], r["params"]) == r["params"], axis=1)]
        for label, cells, ns in condition_rows(
            px, lambda g: g["f1"], lambda g: [None] * len(g),
            "per pixel; ", "oracle: best setting on these data", px_tuned,
        ):
            v = verdict(cells, F1_MARGIN, 0.01, True)
            if v:
                per_pixel.append(finding("visibility", label, v, quick, ns))
    # Each dataset's per-pixel row right after its per-point row.
    dataset_of = lambda c: c.split(" (")[0]  # noqa: E731
    out, left = [], list(per_pixel)
    for f in per_point:
        out.append(f)
        for i, x in enumerate(left):
            if dataset_of(x["condition"]) == dataset_of(f["condition"]):
                out.append(left.pop(i))
                break
    return out + left


# --- robustness -----------------------------------------------------------------------------------


def level_groups(frame: pd.DataFrame) -> dict[tuple[str, float], str]:
    out = {}
    for d, g in frame.groupby("degradation"):
        levels = sorted(set(g["level"]))
        if len(levels) < 2:
            continue
        split = (len(levels) + 1) // 2
        for part, w in [(levels[:split], "milder"), (levels[split:], "harsher")]:
            if not part:
                continue
            fmt = repr_float
            rng = f"level {fmt(part[0])}" if len(part) == 1 else f"levels {fmt(part[0])} to {fmt(part[-1])}"
            for x in part:
                out[(d, x)] = f"{d}, {w} {len(part)} of {len(levels)}: {rng}"
    return out


def robustness_findings(folder: Path, quick: bool) -> list[dict]:
    rows = pd.read_csv(folder / "results.csv", keep_default_na=False, na_values=["NaN"])
    rows["f1"] = rows["f1"].astype(float)
    params = metadata(folder).get("parameters", {})
    recorded = params.get("dataset_roles", {}) or {}
    tuned_on = params.get("tuned_on") or []
    names = list(dict.fromkeys(rows["dataset"]))
    scans = [d for d in names if ((rows["dataset"] == d) & (rows["degradation"] == "scan")).any()]
    evaluation = [d for d in names if role(d, recorded) == "evaluation" and d not in scans]
    oracle = "oracle: `best` tuned on each dataset's own clean cloud, a scan's on itself"
    scan_label = ("simulated scans of the tuning meshes: settings tuned on the clean tuning data, "
                  "not on the scans")
    pools = {}
    for d in names:
        if not tuned_on:
            pools[d] = (2, f"{d} ({oracle})")
        elif d in scans:
            pools[d] = (3, f"{', '.join(scans)} ({scan_label})")
        elif d in evaluation:
            pools[d] = (0, f"{d} ({OUT_OF_SAMPLE})" if len(evaluation) == 1
                        else f"{POOLED}: {', '.join(evaluation)} ({OUT_OF_SAMPLE})")
        elif d in tuned_on:
            pools[d] = (1, f"{d} ({IN_SAMPLE})")
        else:
            pools[d] = (2, f"{d} (own data: settings tuned on the clean tuning data)")
    rows["order"] = rows["dataset"].map(lambda d: pools[d][0])
    rows["pool"] = rows["dataset"].map(lambda d: pools[d][1])
    groups = {pool: level_groups(g) for pool, g in rows.groupby("pool")}
    ok = rows[rows["status"] == "ok"].copy()
    ok["group"] = [groups[r.pool].get((r.degradation, r.level), r.degradation) for r in ok.itertuples()]
    ok["level_text"] = ok["level"].map(lambda x: repr_float(x))
    conditions = []
    for r in ok[["order", "pool", "group"]].itertuples(index=False):
        if tuple(r) not in conditions:
            conditions.append(tuple(r))
    conditions.sort(key=lambda c: c[0])
    out = []
    for order, pool, group in conditions:
        g = ok[(ok["pool"] == pool) & (ok["group"] == group)]
        cells = pd.DataFrame({
            "method": g["method"], "setting": g["setting"],
            "key": g["dataset"] + " " + g["level_text"] + " " + g["view"].astype(str),
            "value": g["f1"], "cost": g["seconds"].astype(float), "answer": None})
        v = verdict(cells, F1_MARGIN, 0.01, True)
        if v:
            out.append(finding("robustness", f"{group} — {pool}", v, quick))
    return out


def repr_float(x: float) -> str:
    """A level as the Rust findings key it (Display of f64: shortest round-trip)."""
    return str(int(x)) if float(x).is_integer() else repr(float(x))


# --- lod ------------------------------------------------------------------------------------------


def curve(points) -> list[tuple[float, float]]:
    best: dict[float, float] = {}
    for n, v in points:
        if n > 0 and math.isfinite(v):
            best[n] = max(best.get(n, -math.inf), v)
    return sorted((math.log(n), v) for n, v in best.items())


def at(c, points: float):
    if not c:
        return None
    x = math.log(points)
    if x < c[0][0] or x > c[-1][0]:
        return None
    for (x0, y0), (x1, y1) in zip(c, c[1:]):
        if x0 <= x <= x1:
            return y0 if x == x0 else y1 if x == x1 else y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    return c[0][1]


def integral(c, lo, hi) -> float:
    total = 0.0
    for (x0, y0), (x1, y1) in zip(c, c[1:]):
        a, b = max(x0, lo), min(x1, hi)
        if b > a:
            f = lambda x: y0 + (y1 - y0) * (x - x0) / (x1 - x0)  # noqa: E731
            total += (b - a) * 0.5 * (f(a) + f(b))
    return total


def bd(a, r):
    if not a or not r:
        return None
    lo, hi = max(a[0][0], r[0][0]), min(a[-1][0], r[-1][0])
    if hi <= lo or sum(1 for x, _ in a if lo <= x <= hi) < 2:
        return None
    return (integral(a, lo, hi) - integral(r, lo, hi)) / (hi - lo)


def lod_at_distance(dataset: str, dist: float, ok: pd.DataFrame, n: float, quick: bool) -> list:
    """One dataset's findings at one distance: a row per budget, then BD-PSNR; each view a cell."""
    out = []
    where = f"{dataset} at distance \u00d7{repr_float(dist)}"
    curves = {}
    for (m, view), g in ok.groupby(["method", "view"]):
        vals = [(float(p), math.nan if s >= IDENTICAL_PSNR else float(s))
                for p, s in zip(g["points_rendered"], g["psnr"])]
        curves.setdefault(m, {})[str(view)] = curve(vals)
    for b in LOD_BUDGETS:
        points = float(math.floor(b * n + 0.5))  # Rust's round: half away from zero
        cells = [(m, k, at(c, points)) for m, by in curves.items() for k, c in by.items()]
        cells = pd.DataFrame([(m, "", k, v, points, None) for m, k, v in cells if v is not None],
                             columns=["method", "setting", "key", "value", "cost", "answer"])
        v = verdict(cells, PSNR_MARGIN, None, True) if not cells.empty else None
        if v:
            missing = [f"{m}: not reached" for m in sorted(curves) if m not in set(cells["method"])]
            pct = f"{b * 100:.6g}"
            out.append(finding("lod", f"{where}, at {pct} % of the points ({points:.0f})",
                               v, quick, missing))
    anchor = curves.get(BD_ANCHOR)
    if anchor is None:
        return out
    cells = [(m, k, bd(c, anchor.get(k, []))) for m, by in curves.items() if m != BD_ANCHOR
             for k, c in by.items()]
    cells = pd.DataFrame([(m, "", k, v, math.nan, None) for m, k, v in cells if v is not None],
                         columns=["method", "setting", "key", "value", "cost", "answer"])
    v = verdict(cells, PSNR_MARGIN, None, True) if not cells.empty else None
    if v:
        missing = [f"{m}: not comparable" for m in sorted(curves)
                   if m != BD_ANCHOR and m not in set(cells["method"])]
        out.append(finding(
            "lod", f"{where}, BD-PSNR against {BD_ANCHOR} over each view's common range of log "
                   "points", v, quick, missing))
    return out


def lod_findings(folder: Path, quick: bool) -> list[dict]:
    rows = pd.read_csv(folder / "results.csv", keep_default_na=False, na_values=["NaN"])
    if "n_points" not in rows:
        rows["n_points"] = 0
    out = []
    for dataset in dict.fromkeys(rows["dataset"]):
        ok = rows[(rows["dataset"] == dataset) & (rows["status"] == "ok")]
        if ok.empty:
            continue
        n = float(ok["n_points"].max()) or float(ok["points_rendered"].max())
        for dist in sorted(set(ok["distance"].astype(float))):
            out.extend(lod_at_distance(dataset, dist, ok[ok["distance"].astype(float) == dist], n,
                                       quick))
    return out


# --- hull -----------------------------------------------------------------------------------------


def paired_ratio(pairs: list[tuple[int, float, float]]):
    ok = [(v, p, o) for v, p, o in pairs if p > 0 and o > 0 and math.isfinite(p) and math.isfinite(o)]
    if not ok:
        return None
    logs = [math.log(p / o) for _, p, o in ok]
    mean, interval = bootstrap(logs) if len({v for v, _, _ in ok}) >= MIN_VIEWS else (float(np.mean(logs)), None)
    return math.exp(mean), (tuple(math.exp(x) for x in interval) if interval else None)


def hull_findings(folder: Path, quick: bool) -> list[dict]:
    rows = pd.read_csv(folder / "results.csv", keep_default_na=False, na_values=["NaN"])
    wrong = wrong_hulls(folder)
    ok = rows[(rows["status"] == "ok") & (rows["perturb"] == 0.0) & (rows["seconds"] > 0)]
    out = []
    for dataset in dict.fromkeys(ok["dataset"]):
        d = ok[ok["dataset"] == dataset]
        tried = sorted(set(d["hull"]))
        cells = {h: {(int(r.view), float(r.gamma)): float(r.seconds) for r in g.itertuples()}
                 for h, g in d.groupby("hull") if h not in wrong}
        if not cells:
            continue
        every = set().union(*[set(c) for c in cells.values()])
        if any(len(c) == len(every) for c in cells.values()):
            keys = sorted(every)
        else:
            most = None
            for h in sorted(cells):
                if most is None or len(cells[h]) > len(cells[most]):
                    most = h
            keys = sorted(cells[most])
        complete = [h for h in sorted(cells) if all(k in cells[h] for k in keys)]
        geomean = {h: math.exp(sum(math.log(cells[h][k]) for k in keys) / len(keys)) for h in complete}
        ranked = sorted(complete, key=lambda h: (geomean[h], h))
        best = ranked[0]
        ratio = None
        if len(ranked) > 1:
            ratio = paired_ratio([(k[0], cells[ranked[1]][k], cells[best][k]) for k in keys])
        if len(ranked) == 1:
            w = "only method"
        elif ratio is None or ratio[1] is None:
            w = "indicative"
        else:
            w = word(ratio[1][0], ratio[1][1], 1.0, TIME_MARGIN)
        nr = notes(wrong, tried) + [
            f"{h}: {sum(1 for k in cells[h] if k in keys)} of {len(keys)} cells"
            for h in sorted(cells) if h not in complete]
        out.append({
            "experiment": "hull",
            "condition": f"{dataset}, {len(complete)} of {len(tried)} hulls on all {len(keys)} (view, γ) cells",
            "method": best, "setting": "", "value": geomean[best], "low": None, "high": None,
            "n_views": len(keys), "indicative": quick or len(keys) < MIN_VIEWS, "identical": "",
            "not_ranked": "; ".join(nr), "cost": geomean[best],
            "runner_up": ranked[1] if len(ranked) > 1 else "",
            "runner_up_value": geomean[ranked[1]] if len(ranked) > 1 else None,
            "difference": ratio[0] if ratio else None,
            "difference_low": ratio[1][0] if ratio and ratio[1] else None,
            "difference_high": ratio[1][1] if ratio and ratio[1] else None,
            "verdict": w, "cheapest": "", "cheapest_value": None, "cheapest_cost": None,
        })
    return out


# --- scale ----------------------------------------------------------------------------------------


def points_text(n: int) -> str:
    k = round(math.log10(n)) if n > 0 else 0
    return f"10^{k}" if k > 0 and 10 ** k == n else str(n)


NORMALS_CELLS = {"normals-ours", "normals-ours-oriented", "normals-open3d",
                 "normals-open3d-oriented", "normals-pcu"}


def scale_group(m: str) -> int:
    # The normal-estimation family is a group of its own, judged by its ratios, not here.
    if m in NORMALS_CELLS:
        return 3
    if m.startswith("hull-"):
        return 1
    if m.endswith("-build") or m.endswith("-select") or m.endswith(OOC_SUFFIX):
        return 2
    return 0


def scale_findings(folder: Path, quick: bool) -> list[dict]:
    rows = pd.read_csv(folder / "results.csv", keep_default_na=False, na_values=["NaN"])
    rows["seconds"] = rows["seconds"].astype(float)
    root = folder.parent
    wrong = {}
    if folder.name == "scale":  # a reports folder's: its siblings' wrong answers count
        wrong = {f"hull-{h}": j for h, j in wrong_hulls(root / "hull").items()}
        wrong.update(wrong_peers(root / "visibility"))

    def in_group(m: str, g: int) -> bool:
        ooc = m.endswith(OOC_SUFFIX)
        if g in (0, 1):
            return scale_group(m) == g
        if g == 2:
            return scale_group(m) == 2 and not m.endswith("-select") and not ooc
        return ooc

    out = []
    for g, name in [(0, "visibility methods (one view; per-cloud build apart)"), (1, "hulls"), (2, "LOD builds in core"),
                    (3, "LOD builds out of core")]:
        mine = rows[[in_group(m, g) for m in rows["method"]]]
        ok = mine[(mine["status"] == "ok") & np.isfinite(mine["seconds"]) & ~mine["method"].isin(wrong)]
        if ok.empty:
            continue
        tried = len(dict.fromkeys(mine["method"]))
        largest = int(ok["n_points"].max())
        sizes = [largest]
        if largest > SCALE_SIZE and (ok["n_points"] == SCALE_SIZE).any():
            sizes.insert(0, SCALE_SIZE)
        ns = notes(wrong, mine["method"])
        for n in sizes:
            at_n = ok[ok["n_points"] == n].sort_values(["seconds", "method"], kind="stable")
            best = at_n.iloc[0]
            lightest = at_n.sort_values(["peak_rss_bytes", "method"], kind="stable").iloc[0]
            runner = at_n.iloc[1] if len(at_n) > 1 else None
            w = ("only method" if runner is None
                 else "wins" if runner["seconds"] > best["seconds"] * (1 + TIME_MARGIN)
                 else "no clear winner")
            out.append({
                "experiment": "scale",
                "condition": f"{name} at {points_text(n)} points"
                             f"{', the largest any finished' if n == largest else ''} "
                             f"({len(at_n)} of {tried} finished)",
                "method": best["method"], "setting": "", "value": best["seconds"], "low": None,
                "high": None, "n_views": None, "indicative": quick, "identical": "",
                "not_ranked": "; ".join(ns), "cost": best["peak_rss_bytes"] / 1048576.0,
                "runner_up": runner["method"] if runner is not None else "",
                "runner_up_value": runner["seconds"] if runner is not None else None,
                "difference": None, "difference_low": None, "difference_high": None,
                "verdict": w, "cheapest": lightest["method"],
                "cheapest_value": lightest["seconds"],
                "cheapest_cost": lightest["peak_rss_bytes"] / 1048576.0,
            })
    return out


# --- the comparison -------------------------------------------------------------------------------

EXPERIMENTS = [
    ("hull", hull_findings), ("visibility", visibility_findings),
    ("robustness", robustness_findings), ("lod", lod_findings), ("scale", scale_findings),
]
EXACT = ["method", "setting", "runner_up", "identical", "not_ranked", "cheapest", "verdict",
         "n_views", "indicative"]
NUMBERS = ["value", "runner_up_value", "difference", "cost", "cheapest_value", "cheapest_cost"]
INTERVALS = [("low", "high", "value"), ("difference_low", "difference_high", "difference")]


def recompute(reports: Path) -> list[dict]:
    out = []
    for name, fn in EXPERIMENTS:
        folder = reports / name
        if (folder / "results.csv").is_file():
            quick = bool(metadata(folder).get("quick", False))
            out.extend(fn(folder, quick))
    return out


def number(x):
    if x is None or (isinstance(x, str) and x.strip() == ""):
        return None
    x = float(x)
    return None if math.isnan(x) else x


def same_number(a, b, rel=1e-9) -> bool:
    a, b = number(a), number(b)
    if a is None or b is None:
        return a is None and b is None
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= rel * max(1.0, abs(a), abs(b))


def compare(written: pd.DataFrame, ours: list[dict]) -> list[str]:
    problems = []
    order = {e: i for i, (e, _) in enumerate(EXPERIMENTS)}
    written = written.fillna("")
    mine = [f for f in ours]
    got = [(r["experiment"], r["condition"]) for _, r in written.iterrows() if r["experiment"] in order]
    want = [(f["experiment"], f["condition"]) for f in mine]
    for key in want:
        if key not in got:
            problems.append(f"missing row: {key[0]} | {key[1]}")
    for key in got:
        if key not in want:
            problems.append(f"row not recomputed (wrong condition or rule): {key[0]} | {key[1]}")
    if [k for k in got if k in want] != [k for k in want if k in got]:
        problems.append("the rows are not in the recomputed order")
    by_key = {(f["experiment"], f["condition"]): f for f in mine}
    for _, row in written.iterrows():
        key = (row["experiment"], row["condition"])
        f = by_key.get(key)
        if f is None:
            continue
        where = f"{key[0]} | {key[1]}"
        for col in EXACT:
            a, b = text(row.get(col, "")), text(f[col])
            if col == "indicative":
                a, b = str(a).lower(), str(b).lower()
            if col == "n_views" and a and b:
                a, b = str(int(float(a))), str(int(float(b)))
            if a != b:
                problems.append(f"{where}: {col} is {a!r}, recomputed {b!r}")
        for col in NUMBERS:
            if not same_number(row.get(col, ""), f[col]):
                problems.append(f"{where}: {col} is {row.get(col, '')!r}, recomputed {f[col]!r}")
        for lo_c, hi_c, mid in INTERVALS:
            lo, hi = number(row.get(lo_c, "")), number(row.get(hi_c, ""))
            olo, ohi = number(f[lo_c]), number(f[hi_c])
            if (lo is None) != (olo is None):
                problems.append(f"{where}: {lo_c} is {lo!r}, recomputed {olo!r}")
                continue
            if lo is None:
                continue
            # Two seeded bootstraps of the same values: within a quarter of the width (and a
            # sliver of the values' scale, for a degenerate interval).
            tol = 0.25 * max(hi - lo, ohi - olo) + 1e-9 * max(1.0, abs(lo), abs(hi))
            if abs(lo - olo) > tol or abs(hi - ohi) > tol:
                problems.append(f"{where}: interval [{lo}, {hi}] is not this bootstrap's "
                                f"[{olo}, {ohi}]")
        # The verdict word from the written interval, by the margin rule.
        margin = number(row.get("margin", "")) or 0.0
        dlo, dhi = number(row.get("difference_low", "")), number(row.get("difference_high", ""))
        if row["verdict"] not in ("only method", "indicative") and dlo is not None and key[0] != "scale":
            center = 1.0 if key[0] == "hull" else 0.0
            if word(dlo, dhi, center, margin) != row["verdict"]:
                problems.append(f"{where}: verdict {row['verdict']!r} does not follow from its "
                                f"interval [{dlo}, {dhi}] and margin {margin}")
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("reports", type=Path, help="a reports folder (findings.csv, NAME/results.csv)")
    parser.add_argument("--verbose", action="store_true", help="print every recomputed row")
    args = parser.parse_args()
    path = args.reports / "findings.csv"
    if not path.is_file():
        print(f"audit: {path} does not exist", file=sys.stderr)
        return 2
    written = pd.read_csv(path, keep_default_na=False, dtype=str)
    ours = recompute(args.reports)
    if args.verbose:
        for f in ours:
            print(f"{f['experiment']} | {f['condition']} | {f['method']} {f['setting']} | "
                  f"{f['value']:.6g} | {f['runner_up']} | {f['verdict']}")
    problems = compare(written, ours)
    if problems:
        print(f"audit: {len(problems)} difference(s) between {path} and its recomputation:")
        for p in problems:
            print(f"  - {p}")
        return 1
    print(f"audit: every one of the {len(ours)} findings of {args.reports} recomputed (pandas "
          f"{pd.__version__}): identical")
    return 0


if __name__ == "__main__":
    sys.exit(main())
