#!/usr/bin/python3
"""Looks at the particles of a poured heap (docs/drop-sequence.md, "The aggregate as a
poured material"). Standard library only.

    scripts/heap-diagnostics.py consistency HEAP.csv [--dp 0.01] [--h-factor 1.5]
    scripts/heap-diagnostics.py state HEAP.csv
    scripts/heap-diagnostics.py slope [--beta 30 36.2 42]

HEAP.csv is what the heap test writes with TAMP_HEAP_DUMP (r, z, vr, vz, density, srr, szz,
stt, srz, mass; SI units, stress tension positive, ring masses).

consistency: by depth below the top of the particle's radial band (width dp), the medians of
  the continuity density, the mean stress, the neighbours within the kernel support, the
  nearest neighbour (in dp) and the kernel moments of the code's strain-rate loop
  (kernels/SphSolid.hpp): the Shepard sum sum_b V_b W_ab and B = sum_b V_b (x_b - x_a) (x)
  grad_a W_ab with V_b = m_b / (2 pi r_a rho_a). In a full, consistent neighbourhood both
  are 1 (B the identity); the Shepard sum is 0.75 in the top row of a square lattice under a
  flat surface and 0.99 one row down. Particles within 2h of the axis or the base (whose
  mirror images are not in the file) are left out.
state: the particles grouped by speed (at rest < 2 mm/s, slow < 2 cm/s, moving), with how
  many carry exactly zero stress (the apex of the cohesionless Mohr-Coulomb cone, or a
  separated grain), the median mean stress and the median continuity density.
slope: the residual acceleration (in g) of the top layers of an ideal square lattice (planar,
  dp 0.01 m, h 1.5 dp, Wendland C2, rho 1835 kg/m3) under the infinite-slope stress field of
  a flowed non-dilatant layer (sigma_xx = sigma_yy = -rho g d cos beta, tau = rho g d sin beta,
  d the depth normal to the slope, the free surface half a spacing above the top row), plus
  gravity: what the SPH pair sum of the code's momentum equation leaves unbalanced at an
  ideal free surface.
"""
import argparse
import csv
import math
import statistics as st


def wendland(h):
    norm = 7.0 / (4.0 * math.pi * h * h)

    def W(q):
        t = 1.0 - 0.5 * q
        return norm * t ** 4 * (2.0 * q + 1.0) if q < 2.0 else 0.0

    def dW(q):
        t = 1.0 - 0.5 * q
        return norm / h * (-5.0 * q) * t ** 3 if q < 2.0 else 0.0

    return W, dW


def read(path):
    rows = list(csv.DictReader(open(path)))
    return {k: [float(x[k]) for x in rows] for k in rows[0]}


def band_depths(d, dp):
    top = {}
    for r, z in zip(d["r"], d["z"]):
        k = int(r / dp)
        top[k] = max(top.get(k, -1e9), z)
    return [top[int(r / dp)] - z for r, z in zip(d["r"], d["z"])]


def consistency(a):
    d = read(a.heap)
    dp, h = a.dp, a.h_factor * a.dp
    W, dW = wendland(h)
    r, z, rho, m = d["r"], d["z"], d["density"], d["mass"]
    p = [-(d["srr"][i] + d["szz"][i] + d["stt"][i]) / 3 for i in range(len(r))]
    depth = band_depths(d, dp)
    res = {}
    for i in range(len(r)):
        if r[i] < 2 * h or z[i] < 2 * h:
            continue
        inv = 1.0 / (2 * math.pi * r[i] * rho[i])
        S = m[i] * inv * W(0.0)
        B00 = B11 = B01 = 0.0
        n = 0
        nearest = 1e9
        for j in range(len(r)):
            if j == i:
                continue
            dr, dz = r[i] - r[j], z[i] - z[j]
            dist = math.hypot(dr, dz)
            nearest = min(nearest, dist)
            if dist >= 2 * h:
                continue
            n += 1
            f = dW(dist / h) / dist
            V = m[j] * inv
            B00 -= V * dr * f * dr
            B01 -= V * dr * f * dz
            B11 -= V * dz * f * dz
            S += V * W(dist / h)
        res[i] = (rho[i], p[i], n, nearest / dp, S, B00, B11, B00 * B11 - B01 * B01)
    print("depth below band top | n | rho | p (Pa) | neighbours | nearest/dp | Shepard | B_rr | B_zz | det B")
    for lo, hi in [(0, 0.5), (0.5, 1.5), (1.5, 2.5), (2.5, 4), (4, 1e9)]:
        sel = [i for i in res if lo * dp <= depth[i] < hi * dp]
        if not sel:
            continue
        med = [st.median(res[i][k] for i in sel) for k in range(8)]
        label = f"{lo}-{hi} dp" if hi < 1e9 else f">{lo} dp"
        print(f"{label:>20} | {len(sel):3d} | {med[0]:5.0f} | {med[1]:6.0f} | {med[2]:3.0f} | {med[3]:.2f} | "
              f"{med[4]:.2f} | {med[5]:.2f} | {med[6]:.2f} | {med[7]:.2f}")


def state(a):
    d = read(a.heap)
    groups = {}
    for i in range(len(d["r"])):
        v = math.hypot(d["vr"][i], d["vz"][i])
        s = [d[k][i] for k in ("srr", "szz", "stt", "srz")]
        key = "moving" if v > 0.02 else ("slow" if v > 0.002 else "at rest")
        groups.setdefault(key, []).append((all(x == 0.0 for x in s), -(s[0] + s[1] + s[2]) / 3 + 0.0, d["density"][i]))
    print("speed | particles | zero stress | median p (Pa) | median density (kg/m3)")
    for key in ("at rest", "slow", "moving"):
        g = groups.get(key, [])
        if g:
            print(f"{key} | {len(g)} | {sum(1 for x in g if x[0])} | {st.median(x[1] for x in g):.0f} | "
                  f"{st.median(x[2] for x in g):.0f}")


def slope(a):
    dp, rho, g = 0.01, 1835.0, 9.81
    h = 1.5 * dp
    _, dW = wendland(h)
    m = rho * dp * dp
    pts = [(i * dp, -(k + 0.5) * dp) for k in range(12) for i in range(-25, 26)]
    for beta_deg in a.beta:
        b = math.radians(beta_deg)

        def sig(y):
            depth = -y
            syy = -rho * g * math.cos(b) * depth  # depth measured normal to the slope
            return syy, syy, rho * g * math.sin(b) * depth

        out = []
        for k in range(5):
            xa, ya = 0.0, -(k + 0.5) * dp
            sa = sig(ya)
            fx = fy = 0.0
            for xb, yb in pts:
                dx, dy = xa - xb, ya - yb
                dist = math.hypot(dx, dy)
                if dist == 0.0 or dist >= 2 * h:
                    continue
                f = dW(dist / h) / dist
                sb = sig(yb)
                Txx, Tyy, Txy = (m * (sa[c] + sb[c]) / rho ** 2 for c in range(3))
                fx += Txx * f * dx + Txy * f * dy
                fy += Txy * f * dx + Tyy * f * dy
            fx += g * math.sin(b)  # x down the slope, y out of it
            fy -= g * math.cos(b)
            out.append(f"row {k}: {fx / g:+.3f} / {fy / g:+.3f}")
        print(f"beta {beta_deg:g} deg, residual (down the slope / out of it, in g): " + ", ".join(out))


ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
sub = ap.add_subparsers(dest="what", required=True)
c = sub.add_parser("consistency")
c.add_argument("heap")
c.add_argument("--dp", type=float, default=0.01)
c.add_argument("--h-factor", type=float, default=1.5)
s = sub.add_parser("state")
s.add_argument("heap")
sl = sub.add_parser("slope")
sl.add_argument("--beta", type=float, nargs="+", default=[30.0, 36.2, 42.0])
args = ap.parse_args()
{"consistency": consistency, "state": state, "slope": slope}[args.what](args)
