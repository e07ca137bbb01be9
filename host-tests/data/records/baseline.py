#!/usr/bin/env python3
"""Replays every record under host-tests/data/records/ with
`beamctl replay FILE --json` and a list of flag sets, and scores each
estimate against the record's reference.json (the acceptance rule there).
Prints a markdown table; with --json PATH also writes every result
(with each report's verdict and `prewhitening`).

    cargo build --release -p beamctl
    python3 host-tests/data/records/baseline.py [--beamctl PATH] [--json PATH]
        [--summary | --best] [--from PATH]

--summary: one row per record (no flags, and the flag sets that pass);
--best: one row per record, no flags against the best flag set, each
with its error ÷ tolerance and the report's verdict (BENCHMARKS.md);
--from PATH: read the results a run wrote with --json instead of
replaying again.

Scoring (the same for every flag set):
- white_noise_crb, model_mismatch, real_reference: the scored reference
  modes (ascending) are paired with the estimated modes — in order when
  the counts agree, otherwise each reference mode with the estimated mode
  nearest in log ω (a reference mode left without one is "missing"). For
  each pair e_ω = |ω̂−ω|/ω ÷ tol_ω and e_ζ = |ζ̂−ζ|/ζ ÷ tol_ζ; the row shows
  the largest of each. For real_reference only the estimated modes are
  scored (each against its nearest scored reference mode): a record may
  hold more modes than the model asks for. PASS: an estimate, no validity
  flag, every e ≤ 1 and no missing mode.
- unidentifiable: PASS when the report does not present an estimate of an
  unexcited mode as good: exit status 1 (no estimate), a non-empty
  `validity`, or every reported mode within 1% in ω of an excited mode
  (acceptance.excited_modes). (The reports' `verdict` must also read
  trusted: false there: python/tests/test_records.py asserts it.)

The first flag set is no flags: `--estimator auto`, the model chosen from
the data (docs/REPLAY.md, "Model selection"); the row says what it chose
and the verdict.
"""

import argparse
import json
import math
import subprocess
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]

FLAG_SETS = [
    [],
    ["--estimator", "robust"],
    ["--level-correction"],
    ["--estimator", "robust", "--level-correction"],
    ["--estimator", "feedthrough"],
    ["--estimator", "feedthrough", "--level-correction"],
    ["--modes", "1"],
    ["--modes", "3"],
    ["--estimator", "robust", "--modes", "1"],
    ["--estimator", "robust", "--modes", "3"],
    ["--estimator", "robust", "--level-correction", "--modes", "1"],
    ["--estimator", "robust", "--level-correction", "--modes", "3"],
]


def run(beamctl, rec, flags):
    p = subprocess.run([str(beamctl), "replay", str(rec), "--json", *flags],
                       capture_output=True, text=True)
    out = None
    if p.stdout.strip():
        try:
            out = json.loads(p.stdout)
        except json.JSONDecodeError:
            out = None
    return p.returncode, out, p.stderr.strip()


def score(ref, rc, out):
    acc = ref["acceptance"]
    rule = acc["rule"]
    est = (out or {}).get("estimate")
    validity = (out or {}).get("validity") or []
    if rule == "unidentifiable":
        # not presented as good: no estimate, or flagged; or every reported
        # mode is an excited one (within 1% in ω), none an unexcited one
        ok = rc == 1 or bool(validity)
        exc = acc.get("excited_modes", {}).get("omega_rad_s", [])
        if not ok and est is not None and exc:
            ok = all(w is not None and any(abs(w - e) / e <= 0.01 for e in exc) for w in est["omega"])
        return {"pass": ok, "e_omega": None, "e_zeta": None, "missing": 0}
    if est is None or rc != 0:
        return {"pass": False, "e_omega": None, "e_zeta": None, "missing": None}
    nan = float("nan")
    w_hat = [nan if x is None else x for x in est["omega"]]
    z_hat = [nan if x is None else x for x in est["zeta"]]
    b_hat = [nan if x is None else x for x in est["bbar"]]
    if rule == "real_reference":
        scored = [m for m in ref["modes"] if m["scored"]]
        rw = [m["omega_rad_s"] for m in scored]
        rz = [m["zeta"] for m in scored]
        rb = [None] * len(rw)
    else:
        k = acc["modes_scored"]
        rw = ref["truth"]["omega_rad_s"][:k]
        rz = ref["truth"]["zeta"][:k]
        rb = ref["truth"]["bbar"][:k]
    tw, tz = acc["omega_rel_tol"], acc["zeta_rel_tol"]
    pairs = []  # (ref index, est index)
    missing = 0
    if rule == "real_reference":
        for j, w in enumerate(w_hat):
            if not (w > 0):
                missing += 1
                continue
            i = min(range(len(rw)), key=lambda i: abs(math.log(w / rw[i])))
            pairs.append((i, j))
    elif len(w_hat) == len(rw):
        pairs = list(zip(range(len(rw)), range(len(w_hat))))
    else:
        for i, w in enumerate(rw):
            c = [j for j in range(len(w_hat)) if w_hat[j] > 0]
            if not c:
                missing += 1
                continue
            j = min(c, key=lambda j: abs(math.log(w_hat[j] / w)))
            pairs.append((i, j))
    ew = [abs(w_hat[j] - rw[i]) / rw[i] / tw[i] for i, j in pairs]
    ez = [abs(z_hat[j] - rz[i]) / rz[i] / tz[i] for i, j in pairs]
    eb = [abs(b_hat[j] - rb[i]) / abs(rb[i]) for i, j in pairs if rb[i] is not None]
    ok = (not validity) and missing == 0 and all(e <= 1 for e in ew + ez) and bool(pairs)
    ew = [e for e in ew if e == e]
    ez = [e for e in ez if e == e]
    eb = [e for e in eb if e == e]
    return {"pass": ok, "e_omega": max(ew) if ew else None, "e_zeta": max(ez) if ez else None,
            "bbar_rel_err": max(eb) if eb else None, "missing": missing,
            "pairs": pairs}


def fmt(x):
    if x is None:
        return "–"
    if x >= 1e4:
        return f"{x:.1e}"
    if x >= 100:
        return f"{x:.0f}"
    return f"{x:.2g}"


def describe(rc, out, err):
    if out is None:
        return f"exit {rc}: {err.splitlines()[-1][:90] if err else 'no output'}"
    est = out.get("estimate")
    sup = out.get("supervision") or {}
    parts = [f"exit {rc}"]
    if out.get("selection") is not None:
        lc = "LC" if out.get("level_correction") else "no LC"
        parts.append(f"chose {out['estimator']} {out['modes']}m {lc}")
    if out.get("verdict") is not None:
        parts.append("trusted" if out["verdict"]["trusted"] else
                     "not trusted (" + ",".join(r["code"] for r in out["verdict"]["reasons"]) + ")")
    if est is None:
        parts.append("no estimate")
    else:
        parts.append("ω̂ " + "/".join("null" if w is None else f"{w:.5g}" for w in est["omega"]))
        parts.append("ζ̂ " + "/".join("null" if z is None else f"{z:.3g}" for z in est["zeta"]))
    if out.get("validity"):
        parts.append("validity " + ",".join(out["validity"]))
    if out.get("fit_percent") is not None:
        parts.append(f"fit {out['fit_percent']:.1f}%")
    if sup.get("excitation_reason") and sup.get("excitation_reason") != "excited":
        parts.append(sup["excitation_reason"])
    if out.get("tuning") and out.get("tuning") != "converged":
        parts.append(f"tuning {out['tuning']}")
    return ", ".join(parts)


def summary(results):
    print("| record | rule | no flags: e_ω ÷ tol | e_ζ ÷ tol | pass | beamctl reported (no flags) "
          "| flag sets that pass (of the 12 tried) |")
    print("|---|---|---|---|---|---|---|")
    recs = []
    for r in results:
        if r["record"] not in recs:
            recs.append(r["record"])
    for name in recs:
        rows = [r for r in results if r["record"] == name]
        base = rows[0]
        assert base["flags"] == ""
        s = base["score"]
        ok = [f"`{r['flags']}`" for r in rows[1:] if r["score"]["pass"]]
        if not ok and not s["pass"]:
            scored = [r for r in rows[1:] if r["score"]["e_omega"] is not None]
            # prefer estimates without a validity flag
            scored = [r for r in scored if not r["validity"]] or scored
            if scored:
                b = min(scored, key=lambda r: max(r["score"]["e_omega"], r["score"]["e_zeta"] or 0))
                ok = [f"none (closest: `{b['flags']}`, e_ω {fmt(b['score']['e_omega'])}, "
                      f"e_ζ {fmt(b['score']['e_zeta'])})"]
            else:
                ok = ["none"]
        print(f"| {name} | {base['rule']} | {fmt(s['e_omega'])} | {fmt(s['e_zeta'])} | "
              f"{'PASS' if s['pass'] else 'fail'} | {base['reported']} | {'; '.join(ok) or '–'} |")


def verdict_text(r):
    v = r.get("verdict")
    if v is None:
        return "no report"
    if v["trusted"]:
        return "trusted"
    return "not trusted (" + ", ".join(x["code"] for x in v["reasons"]) + ")"


def worst(r):
    """The row's largest error ÷ tolerance (None without a scored estimate)."""
    s = r["score"]
    if s["e_omega"] is None:
        return None
    return max(s["e_omega"], s["e_zeta"] or 0.0)


def best(results):
    """Per record: no flags against the best flag set. Best: for a scored
    record the passing flag set with the smallest error ÷ tolerance (or,
    when none passes, the smallest of all); for an unidentifiable record
    the first flag set the report does not trust."""
    print("| record | rule | no flags: e_ω ÷ tol | e_ζ ÷ tol | verdict | best flags "
          "| e_ω ÷ tol | e_ζ ÷ tol | verdict |")
    print("|---|---|---|---|---|---|---|---|---|")
    recs = []
    for r in results:
        if r["record"] not in recs:
            recs.append(r["record"])
    for name in recs:
        rows = [r for r in results if r["record"] == name]
        base, others = rows[0], rows[1:]
        assert base["flags"] == ""
        if base["rule"] == "unidentifiable":
            cands = [r for r in others if not (r.get("verdict") or {}).get("trusted", False)]
            b = cands[0] if cands else None
        else:
            ok = [r for r in others if r["score"]["pass"] and worst(r) is not None]
            scored = ok or [r for r in others if worst(r) is not None]
            b = min(scored, key=worst) if scored else None
        def cells(r):
            if r is None:
                return "–", "–", "–"
            s = r["score"]
            return fmt(s["e_omega"]), fmt(s["e_zeta"]), verdict_text(r)
        n = cells(base)
        f = cells(b)
        flags = f"`{b['flags']}`" if b is not None else "none"
        print(f"| {name} | {base['rule']} | {n[0]} | {n[1]} | {n[2]} | {flags} | "
              f"{f[0]} | {f[1]} | {f[2]} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--beamctl", default=str(ROOT / "target/release/beamctl"))
    ap.add_argument("--json")
    ap.add_argument("--summary", action="store_true",
                    help="one row per record: no flags, and the flag sets that pass")
    ap.add_argument("--best", action="store_true",
                    help="one row per record: no flags against the best flag set")
    ap.add_argument("--from", dest="source",
                    help="read the results of an earlier --json run instead of replaying")
    args = ap.parse_args()
    if args.source:
        results = json.loads(Path(args.source).read_text())
        if args.best:
            best(results)
        else:
            summary(results)
        return
    results = []
    for refp in sorted(HERE.glob("*/reference.json")):
        rec = refp.parent / "record.csv.gz"
        if not rec.exists():
            continue
        ref = json.loads(refp.read_text())
        for flags in FLAG_SETS:
            rc, out, err = run(args.beamctl, rec.relative_to(ROOT), flags)
            s = score(ref, rc, out)
            results.append({"record": ref["record"], "rule": ref["acceptance"]["rule"],
                            "flags": " ".join(flags), "exit": rc, "score": s,
                            "reported": describe(rc, out, err),
                            "estimate": (out or {}).get("estimate"),
                            "validity": (out or {}).get("validity"),
                            "verdict": (out or {}).get("verdict"),
                            "prewhitening": (out or {}).get("prewhitening")})
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1, ensure_ascii=False) + "\n")
    if args.summary:
        summary(results)
        return
    if args.best:
        best(results)
        return
    print("| record | rule | flags | e_ω ÷ tol | e_ζ ÷ tol | b̄ rel. err | pass | beamctl reported |")
    print("|---|---|---|---|---|---|---|---|")
    for r in results:
        s = r["score"]
        print(f"| {r['record']} | {r['rule']} | {r['flags'] or '(none)'} | {fmt(s['e_omega'])} | "
              f"{fmt(s['e_zeta'])} | {fmt(s.get('bbar_rel_err'))} | {'PASS' if s['pass'] else 'fail'} | "
              f"{r['reported']} |")


if __name__ == "__main__":
    main()
