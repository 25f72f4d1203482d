"""Compare two campaigns' result folders: packings, case records and the C_eq table.

Used for the package's reorganisation (issue 11): the .test campaign run on the commit before
and after a change must give the same packings, records and table.

Usage: .venv/bin/python benchmarks/experiments/compare_campaigns.py BEFORE/results AFTER/results

Records and packings must be identical apart from keys ending in _time_s (and ``cpu_s``); the
table apart from its *_time_s columns. Exits 1 when anything differs.
"""
import json
import pandas as pd
import sys
from pathlib import Path

TIME_KEYS = ("_time_s",)

def strip(obj):
    if isinstance(obj, dict):
        return {k: strip(v) for k, v in obj.items() if not k.endswith("_time_s") and k not in ("cpu_s",)}
    if isinstance(obj, list):
        return [strip(v) for v in obj]
    return obj

def main(a, b):
    a, b = Path(a), Path(b)
    bad = 0
    for sub in ("packings", "cases"):
        fa = sorted(p.name for p in (a / sub).glob("*.json"))
        fb = sorted(p.name for p in (b / sub).glob("*.json"))
        if fa != fb:
            print(f"{sub}: different files: {set(fa) ^ set(fb)}"); bad += 1
        same = 0
        for name in fa:
            ja = strip(json.loads((a / sub / name).read_text()))
            jb = strip(json.loads((b / sub / name).read_text()))
            if ja == jb:
                same += 1
            else:
                bad += 1
                keys = [k for k in set(ja) | set(jb) if ja.get(k) != jb.get(k)]
                print(f"{sub}/{name}: differs in {keys}")
        print(f"{sub}: {same} of {len(fa)} identical (apart from *_time_s)")
    ta, tb = pd.read_csv(a / "ceq_table.csv"), pd.read_csv(b / "ceq_table.csv")
    cols = [c for c in ta.columns if not c.endswith("_time_s")]
    if list(ta.columns) != list(tb.columns):
        print("table: different columns"); bad += 1
    elif ta[cols].equals(tb[cols]):
        print(f"ceq_table.csv: {len(ta)} rows x {len(cols)} columns identical (apart from {len(ta.columns) - len(cols)} *_time_s columns)")
    else:
        bad += 1
        diff = (ta[cols] != tb[cols]) & ~(ta[cols].isna() & tb[cols].isna())
        print("ceq_table.csv differs in columns:", list(diff.columns[diff.any()]))
    print("IDENTICAL" if bad == 0 else f"{bad} DIFFERENCES")
    return 1 if bad else 0

if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
