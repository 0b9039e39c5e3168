#!/usr/bin/env python3
"""Side-by-side comparison of lasalle's centre manifold with hiten's (docs/center_manifold.md):

    lasalle normal-form cr3bp_spatial --at L1 --center-manifold --order 8 --format csv > L1.csv
    python3 scripts/compare_hiten.py hiten.csv L1 L1.csv

hiten (and Jorba & Masdemont) scale lengths by gamma and H by 1/gamma^2, so a coefficient of
degree d is lasalle's times gamma^(d-2). The two linear normalisations differ by a rotation of
the planar centre plane by pi, (Q2, P2) -> (-Q2, -P2), so the reduced coefficients agree up
to the sign (-1)^(a_Q2 + a_P2). The Birkhoff coefficients are invariants: hiten's real full
normal form is read in actions as h_abc = coef(q1^a p1^a q2^2b q3^2c) * 2^(b+c).
"""
import csv
import sys
from collections import defaultdict

hiten_csv, point, ours_csv = sys.argv[1:4]
hit_cm, hit_bnf, hit_lin = {}, {}, {}
for row in csv.reader(open(hiten_csv)):
    if len(row) != 5 or row[0] != point:
        continue
    _, form, e, d, v = row
    if form == "linear":
        hit_lin[e] = float(v)
    elif form == "center_manifold_real":
        hit_cm[tuple(int(x) for x in e.split())] = float(v)
    elif form == "real_full_normal":
        hit_bnf[tuple(int(x) for x in e.split())] = float(v)
ours_red, ours_bnf, ours_lin = {}, {}, {}
for row in csv.DictReader(open(ours_csv)):
    val = float(row["value"]) + float(row["lo"])
    if row["section"] == "reduced":
        ours_red[tuple(int(x) for x in row["exponents"].split())] = (int(row["degree"]), val)
    elif row["section"] == "birkhoff":
        ours_bnf[tuple(int(x) for x in row["exponents"].split())] = (int(row["degree"]), val)
    elif row["section"] in ("lambda", "omega", "gamma"):
        ours_lin[row["name"]] = val
g = ours_lin["gamma"]
print(f"{point}: linear data, lasalle (double-double) vs hiten")
for k in ("lambda", "omega_p", "omega_v", "gamma"):
    a, b = ours_lin[k], hit_lin[k]
    print(f"  {k:8} {a:.16f} {b:.16f}  diff {a - b:+.1e}")
# reduced: ours (Q2, Q3, P2, P3) -> hiten (q1 q2 q3 p1 p2 p3) with q1 = p1 = 0
worst = defaultdict(float)
count = defaultdict(int)
scale = defaultdict(float)
for e, (d, v) in ours_red.items():
    he = (0, e[0], e[1], 0, e[2], e[3])
    s = (-1) ** (e[0] + e[2])
    ours = v * g ** (d - 2) * s
    hv = hit_cm.get(he, 0.0)
    scale[d] = max(scale[d], abs(hv), abs(ours))
    worst[d] = max(worst[d], abs(ours - hv))
    count[d] += 1 if (hv != 0.0 or v != 0.0) else 0
missing = [e for e in hit_cm if (e[0], e[3]) == (0, 0) and (e[1], e[2], e[4], e[5]) not in ours_red]
print(f"\n{point}: reduced Hamiltonian, max |lasalle - hiten| / max |coefficient| per degree")
print("| degree | terms | max abs coefficient | max difference | relative |")
print("|---:|---:|---:|---:|---:|")
for d in sorted(worst):
    if d < 2:
        continue
    print(f"| {d} | {count[d]} | {scale[d]:.3e} | {worst[d]:.1e} | {worst[d] / scale[d]:.1e} |")
if missing:
    print(f"hiten terms missing on our side: {missing[:5]}")
print(f"\n{point}: Birkhoff normal form in actions (I1 = q1 p1, I2, I3), gamma units")
print("| exponents (I1 I2 I3) | lasalle | hiten | relative difference |")
print("|---|---:|---:|---:|")
for e, (d, v) in sorted(ours_bnf.items(), key=lambda x: (x[1][0], x[0])):
    if v == 0.0:
        continue
    a, b, c = e
    he = (a, 2 * b, 2 * c, a, 0, 0)
    if he not in hit_bnf:
        continue
    hv = hit_bnf[he] * 2 ** (b + c)
    ours = v * g ** (d - 2)
    print(f"| {a} {b} {c} | {ours:.15e} | {hv:.15e} | {abs(ours - hv) / abs(ours):.1e} |")
