#!/usr/bin/env python3
"""Markdown tables of a bench_peers run (docs/BENCHMARKS.md, "Peers (CGAL, FCL)").

Usage: build/bin/bench_peers --benchmark_repetitions=10 --benchmark_out=peers.json
       python3 bench/peers_table.py peers.json

Every figure is the median over the repetitions of the per-repetition medians that
bench_peers reports as counters; [lo-hi] is the range of those per-repetition medians.
Ratios are the medians of the per-repetition ratios. Standard library only.
"""
import json
import statistics
import sys
from collections import OrderedDict


def runs(path):
    with open(path) as f:
        data = json.load(f)
    groups = OrderedDict()
    for b in data["benchmarks"]:
        if b.get("run_type") != "iteration" or b.get("error_occurred"):
            continue
        groups.setdefault(b["run_name"], []).append(b)
    return data["context"], groups


def stat(reps, key):
    values = [r[key] for r in reps]
    return statistics.median(values), min(values), max(values)


def ms(reps, key):
    m, lo, hi = stat(reps, key)
    return f"{m:.3g} [{lo:.3g}-{hi:.3g}]"


def ratio(reps, key):
    m, lo, hi = stat(reps, key)
    return f"**{m:.3g}** [{lo:.3g}-{hi:.3g}]"


def count(reps, key):
    """A count of the last frame: one value, or the range over the repetitions."""
    values = sorted({int(r[key]) for r in reps})
    if len(values) == 1:
        return f"{values[0]:,}"
    return f"{values[0]:,}-{values[-1]:,}"


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    context, groups = runs(sys.argv[1])
    reps = {len(v) for v in groups.values()}
    print(f"{context['date']}, {context['num_cpus']} CPUs at {context['mhz_per_cpu']} MHz, "
          f"load average {', '.join(f'{x:.2f}' for x in context.get('load_avg', []))} "
          f"at the start; repetitions: {', '.join(map(str, sorted(reps)))}\n")
    frame = [(k, v) for k, v in groups.items() if k.startswith("Frame/")]
    if frame:
        print("| scene | threads | contacts (ours) | overlapping tet pairs | FCL triangle pairs "
              "| ours, frame ms | ours, detection ms | FCL AABB ms | FCL OBBRSS ms "
              "| ours / FCL AABB | ours / FCL OBBRSS |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for name, r in frame:
            threads = name.split("threads:")[1].split("/")[0]
            print(f"| {r[0]['label']} | {threads} | {count(r, 'contacts')} "
                  f"| {count(r, 'overlapping')} | {count(r, 'fcl_aabb_pairs')} "
                  f"| {ms(r, 'ours_ms')} | {ms(r, 'ours_detect_ms')} | {ms(r, 'fcl_aabb_ms')} "
                  f"| {ms(r, 'fcl_obbrss_ms')} | {ratio(r, 'ours_per_fcl_aabb')} "
                  f"| {ratio(r, 'ours_per_fcl_obbrss')} |")
        print()
    cgal = [(k, v) for k, v in groups.items() if k.startswith("Cgal/")]
    if cgal:
        print("| scene | threads | overlapping tet pairs | candidates CGAL / ours "
              "| CGAL ms | ours, pairs only ms | ours, detect ms | ours, detect_pair ms "
              "| CGAL / pairs only | CGAL / detect | CGAL / detect_pair | mismatches (frames) |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for name, r in cgal:
            threads = name.split("threads:")[1].split("/")[0]
            mismatches = sum(int(x["mismatches"]) for x in r)
            frames = sum(int(x["frames_checked"]) for x in r)
            print(f"| {r[0]['label']} | {threads} | {count(r, 'pairs')} "
                  f"| {count(r, 'cgal_candidates')} / {count(r, 'ours_candidates')} "
                  f"| {ms(r, 'cgal_ms')} | {ms(r, 'ours_pairs_ms')} | {ms(r, 'ours_detect_ms')} "
                  f"| {ms(r, 'ours_detect_pair_ms')} | {ratio(r, 'cgal_per_pairs')} "
                  f"| {ratio(r, 'cgal_per_detect')} | {ratio(r, 'cgal_per_detect_pair')} "
                  f"| {mismatches} ({frames}) |")


if __name__ == "__main__":
    main()
