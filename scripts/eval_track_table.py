#!/usr/bin/env python3
"""make eval-track's tables, from the batch folders of an evaluation (OUT/<group>/<setting>/).

Writes OUT/table.md (every run) and OUT/summary.md (one row per clip, and the totals); with
--docs FILE, puts them between FILE's EVAL-TRACK and EVAL-TRACK-SUMMARY markers.
Usage: eval_track_table.py OUT --groups G1 G2 ... --settings S1 S2 ... [--docs docs/results.md]
"""
import argparse
import csv
import os
import re
import statistics

SEED_SETTINGS = ("seed1", "seed2", "seed3", "seed4", "seed5")


def read_rows(out, groups, settings):
    """(group, clip, setting, row) in the groups' order, clip by clip, setting by setting"""
    rows = []
    for group in groups:
        by_setting = {}
        for setting in settings:
            path = os.path.join(out, group, setting, "results.csv")
            if os.path.exists(path):
                with open(path) as f:
                    by_setting[setting] = {r["clip"]: r for r in csv.DictReader(f)}
        clips = []
        for by_clip in by_setting.values():
            clips += [c for c in by_clip if c not in clips]
        for clip in clips:
            for setting in settings:
                row = by_setting.get(setting, {}).get(clip)
                if row is not None:
                    rows.append((group, clip, setting, row))
    return rows


def fell(r):
    return r["fell"] == "1" or r["diverged"] == "1"


def holds(r):
    """no fall, PHC's success, root within 0.2 m and joints within 6 degrees"""
    return (not r["error"] and not fell(r) and r["success"] == "1"
            and float(r["root_error_m"]) <= 0.2 and float(r["joint_error_deg"]) <= 6)


def num(r, key, digits):
    return "{:.{}f}".format(float(r[key]), digits) if r.get(key) else "-"


def full_table(rows):
    lines = ["| clip | setting | sim s | fell | success | G-MPJPE m | root m | joint deg "
             "| skate m/s | compute s/s | CPU s/s | holds |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, clip, setting, r in rows:
        if r["error"]:
            lines.append("| {} | {} | - | - | - | - | - | - | - | - | - | ERROR: {} |".format(
                clip, setting, r["error"].replace("|", "\\|")))
            continue
        lines.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            clip, setting, num(r, "sim_s", 1),
            "diverged" if r["diverged"] == "1" else ("yes" if fell(r) else "no"),
            "yes" if r["success"] == "1" else "no", num(r, "g_mpjpe_m", 3),
            num(r, "root_error_m", 3), num(r, "joint_error_deg", 2),
            num(r, "foot_skate_m_per_s", 3), num(r, "compute_s_per_sim_s", 1),
            num(r, "cpu_s_per_sim_s", 1), "PASS" if holds(r) else "FAIL"))
    return "\n".join(lines)


def span(values, scale, digits):
    if not values:
        return "-"
    low, high = min(values) * scale, max(values) * scale
    text = "{:.{}f}".format(low, digits)
    return text if high - low < 0.5 * 10 ** -digits else text + "-{:.{}f}".format(high, digits)


def summary_table(rows):
    """one row per clip: how many of its runs hold, the spans of the metrics over its runs, and
    its CPU per simulated second at the defaults (the seed settings)"""
    lines = ["| clip | holds | G-MPJPE cm | root error cm | joint error ° | foot skate m/s "
             "| CPU s per simulated s (defaults) |", "|---|---|---|---|---|---|---|"]
    clips = []
    for _, clip, _, _ in rows:
        if clip not in clips:
            clips.append(clip)
    for clip in clips:
        runs = [r for _, c, _, r in rows if c == clip]
        ok = [r for r in runs if not r["error"]]
        cpu = [float(r["cpu_s_per_sim_s"]) for _, c, s, r in rows
               if c == clip and s in SEED_SETTINGS and r.get("cpu_s_per_sim_s")]

        def values(key):
            return [float(r[key]) for r in ok]
        lines.append("| {} | {} of {} | {} | {} | {} | {} | {} |".format(
            clip, sum(holds(r) for r in runs), len(runs), span(values("g_mpjpe_m"), 100, 1),
            span(values("root_error_m"), 100, 1), span(values("joint_error_deg"), 1, 1),
            span(values("foot_skate_m_per_s"), 1, 2), span(cpu, 1, 1)))
    all_runs = [r for _, _, _, r in rows]
    good = [r for r in all_runs if not r["error"]]
    cpu_defaults = [float(r["cpu_s_per_sim_s"]) for _, _, s, r in rows
                    if s in SEED_SETTINGS and r.get("cpu_s_per_sim_s")]
    lines.append("")
    lines.append("**{} of {} runs hold**, {} fell; median G-MPJPE {:.1f} cm; CPU per simulated "
                 "second at the defaults: median {:.1f} s, at most {:.1f} s.".format(
                     sum(holds(r) for r in all_runs), len(all_runs),
                     sum(fell(r) for r in good),
                     100 * statistics.median(float(r["g_mpjpe_m"]) for r in good),
                     statistics.median(cpu_defaults), max(cpu_defaults)))
    return "\n".join(lines)


def put_between(text, marker, table):
    pattern = r"(<!-- {} BEGIN -->\n).*?(\n<!-- {} END -->)".format(marker, marker)
    new, count = re.subn(pattern, lambda m: m.group(1) + table + m.group(2), text, flags=re.S)
    if count != 1:
        raise SystemExit("eval-track: no <!-- {} BEGIN/END --> markers".format(marker))
    return new


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--groups", nargs="+", required=True)
    parser.add_argument("--settings", nargs="+", required=True)
    parser.add_argument("--docs")
    args = parser.parse_args()
    rows = read_rows(args.out, args.groups, args.settings)
    if not rows:
        raise SystemExit("eval-track: no results.csv under " + args.out)
    table, summary = full_table(rows), summary_table(rows)
    for name, text in (("table.md", table), ("summary.md", summary)):
        with open(os.path.join(args.out, name), "w") as f:
            f.write(text + "\n")
    print(summary)
    if args.docs:
        with open(args.docs) as f:
            text = f.read()
        text = put_between(put_between(text, "EVAL-TRACK", table), "EVAL-TRACK-SUMMARY", summary)
        with open(args.docs, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
