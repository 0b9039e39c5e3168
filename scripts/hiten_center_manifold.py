#!/usr/bin/env python3
"""hiten's centre manifold and full normal form at Earth-Moon L1/L2, as CSV for the
comparison in docs/center_manifold.md:

    python3 -m venv /work/venvs/hiten && /work/venvs/hiten/bin/pip install hiten==0.5.4
    /work/venvs/hiten/bin/python scripts/hiten_center_manifold.py DEGREE [POINTS] [RUNS] [FORMS] > hiten.csv

POINTS is 1, 2 or 12 (default 12: L1 and L2); RUNS is 1 or 2 (default 2: a second call on a
fresh object after the first, which includes numba's compilation); FORMS is `both` (default)
or `cm`, the reduced Hamiltonian alone, without the full normal form (at degree 16 hiten's
full normal form takes hours).

Rows: point,form,exponents(q1 q2 q3 p1 p2 p3),degree,coefficient, plus `linear` rows
(lambda, omega_p, omega_v, gamma) and `timing` rows (seconds, first call including numba
compilation, then a second call on a fresh object).
"""
import sys
import time

import numpy as np
from hiten import System
from hiten.algorithms.polynomial.base import _decode_multiindex

MU = 0.01215058560962404
degree = int(sys.argv[1]) if len(sys.argv) > 1 else 16
points = [int(c) for c in (sys.argv[2] if len(sys.argv) > 2 else "12")]
runs = ("first", "second")[: int(sys.argv[3]) if len(sys.argv) > 3 else 2]
full_normal = (sys.argv[4] if len(sys.argv) > 4 else "both") == "both"
print("point,form,exponents,degree,value", flush=True)
for idx in points:
    for attempt in runs:
        system = System.from_mu(MU)
        point = system.get_libration_point(idx)
        t0 = time.perf_counter()
        from hiten.system.center import CenterManifold
        cm = CenterManifold(point, degree)
        ham = cm.compute("center_manifold_real")
        t1 = time.perf_counter()
        print(f"L{idx},timing,{attempt}_center_manifold,,{t1 - t0}", flush=True)
        forms = [("center_manifold_real", ham)]
        if full_normal:
            full = cm.dynamics.pipeline.get_hamiltonian("real_full_normal")
            print(f"L{idx},timing,{attempt}_full_normal,,{time.perf_counter() - t1}")
            forms.append(("real_full_normal", full))
    lam, wp, wv = point.linear_modes
    print(f"L{idx},linear,lambda,2,{lam!r}")
    print(f"L{idx},linear,omega_p,2,{wp!r}")
    print(f"L{idx},linear,omega_v,2,{wv!r}")
    print(f"L{idx},linear,gamma,,{point.gamma!r}")
    for form, h in forms:
        clmo = h.dynamics.clmo
        for d, arr in enumerate(h.poly_H):
            for pos, c in enumerate(arr):
                c = complex(c)
                if abs(c) == 0.0:
                    continue
                e = _decode_multiindex(pos, d, clmo)
                print(f"L{idx},{form},{' '.join(str(int(x)) for x in e)},{d},{c.real!r}")
