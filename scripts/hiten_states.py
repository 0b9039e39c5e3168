#!/usr/bin/env python3
"""Synodic states of hiten 0.5.4's centre-manifold points (Earth-Moon L1/L2, degree given),
for the check in docs/center_manifold.md:

    /work/venvs/hiten/bin/python scripts/hiten_states.py 8 > hiten_states.csv

Rows: point,q2,p2,q3,p3,x,y,z,vx,vy,vz (hiten's cm_point_to_synodic of (q2, p2, q3, p3)).
"""
import sys

import numpy as np
from hiten import System
from hiten.system.center import CenterManifold

MU = 0.01215058560962404
degree = int(sys.argv[1]) if len(sys.argv) > 1 else 8
print("point,q2,p2,q3,p3,x,y,z,vx,vy,vz", flush=True)
for idx in (1, 2):
    point = System.from_mu(MU).get_libration_point(idx)
    cm = CenterManifold(point, degree)
    cm.compute("center_manifold_real")
    for w in ([0.1, 0.0, 0.0, 0.0], [0.0, 0.1, 0.0, 0.0], [0.05, -0.04, 0.06, 0.03], [0.0, 0.0, 0.1, 0.0]):
        s = cm.dynamics.cm_point_to_synodic(np.array(w), energy=None)
        print(f"L{idx}," + ",".join(repr(float(x)) for x in w) + "," + ",".join(repr(float(x)) for x in s), flush=True)
