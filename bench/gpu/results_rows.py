#!/usr/bin/env python3
"""Markdown rows for bench/RESULTS.md from pflow-bench JSON lines (one file or more).

GPU rows go to the "GPU" table (throughput, device memory per particle, the compulsory traffic of each
phase against the measured copy bandwidth); CPU and LAMMPS rows to the main table's columns.
Usage: results_rows.py bench.jsonl [...]
"""
import datetime
import json
import sys

today = datetime.date.today().isoformat()
gpu, cpu = [], []
for path in sys.argv[1:]:
    for line in open(path):
        j = json.loads(line)
        if j.get("code") == "lammps":
            cpu.append(f'| {today} | {j["commit"]} | {j["device"]} | LAMMPS {j["version"]} | double | {j["case"]} '
                       f'| {j["n"]} | {j["ranks"]} ranks | {j["particle_steps_per_s"]:.3g} | same invocation '
                       f'(pflow {j.get("pflow_precision", "double")}/LAMMPS {j["pflow_over_lammps"]:.2f}) |')
            continue
        if j["executor"] != "cuda":
            cpu.append(f'| {today} | {j["commit"]} | {j["device"]} | pflow cpu (OpenMP) | {j["precision"]} | {j["case"]} '
                       f'| {j["n"]} | {j["threads"]} | {j["particle_steps_per_s"]:.3g} | `{j["command"]}` |')
            continue
        t = j.get("traffic", {})
        share = lambda k: f'{t[k]["gb_per_s"]:.0f} GB/s ({100 * t[k]["of_copy_bandwidth"]:.0f} %)' if k in t else "-"
        ph = j["phases_s"]
        total = sum(ph.values()) or 1
        gpu.append(f'| {today} | {j["commit"]} | {j["device"].split("(")[1].split(",")[0]} | {j["precision"]} '
                   f'| {j["case"]} | {j["n"]} | {j["particle_steps_per_s"]:.3g} | {j["device_bytes_per_particle"]:.0f} '
                   f'| {100 * ph["forces"] / total:.0f} % | {share("forces")} | {share("integrate1")} '
                   f'| {j["coordination"]:.2f} | `{j["command"]}` |')
print("\n".join(gpu))
print()
print("\n".join(cpu))
