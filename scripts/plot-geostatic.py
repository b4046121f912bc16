#!/usr/bin/python3
"""Vertical stress against depth from a Tamp snapshot (like the reference paper's Fig. 5).

    scripts/plot-geostatic.py RESULT_DIR [--surface 0.8]

Reads the last snapshot_*.h5 in RESULT_DIR (particles, and the tied elements when the deck
has [fem]), writes RESULT_DIR/vertical-stress.png and RESULT_DIR/geostatic.md: the mean
vertical stress of the row nearest the bottom of each layer against the paper's figures
(7.48 kPa at the clay bottom, 14.68 kPa at the sand bottom; from the unit weights of
data/lab-test.toml, clay 18.7 and sand 18.0 kN/m3).
"""
import argparse, glob, os, re
import h5py
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

ap = argparse.ArgumentParser()
ap.add_argument("result_dir")
ap.add_argument("--surface", type=float, default=0.8, help="ground surface z, m")
a = ap.parse_args()
snap = sorted(glob.glob(os.path.join(a.result_dir, "snapshot_*.h5")))[-1]
parts = {}  # name -> (z, s_zz) of particles / element centres
with h5py.File(snap, "r") as f:
    g = f["particles"]
    parts["particles"] = (np.asarray(g["z"]), np.asarray(g["s_zz"]))
    if "elements" in f:
        e = f["elements"]
        conn = np.asarray(e["connectivity"])
        parts["elements"] = (np.asarray(e["node_z"])[conn].mean(axis=1), np.asarray(e["s_zz"]))


def exact(depth):  # Pa, compression positive: clay 18.7 kN/m3 over 0.4 m, sand 18.0 below
    return np.where(depth <= 0.4, 18.7e3 * depth, 18.7e3 * 0.4 + 18.0e3 * (depth - 0.4))


fig, ax = plt.subplots(figsize=(5, 6))
for (name, (z, szz)), marker in zip(parts.items(), ("o", "s")):
    ax.scatter(-szz / 1e3, a.surface - z, s=3, marker=marker, label=f"Tamp {name}")
d = np.linspace(0, 0.8, 100)
ax.plot(exact(d) / 1e3, d, "k-", label="gamma z")
ax.invert_yaxis(); ax.set_xlabel("vertical stress, kPa (compression)"); ax.set_ylabel("depth, m")
ax.legend(); ax.grid(alpha=0.3); fig.tight_layout()
fig.savefig(os.path.join(a.result_dir, "vertical-stress.png"), dpi=120)

dz = float(re.search(r"^spacing\s*=\s*([0-9.eE+-]+)", open(os.path.join(a.result_dir, "deck.toml")).read(), re.M).group(1))
m = re.search(r"^element_size\s*=\s*([0-9.eE+-]+)", open(os.path.join(a.result_dir, "deck.toml")).read(), re.M)
sizes = {"particles": dz, "elements": float(m.group(1)) if m else dz}
rows = []
for name, zb, ref in (("clay bottom", 0.4, 7.48e3), ("sand bottom", 0.0, 14.68e3)):
    for what, (z, szz) in parts.items():
        h = sizes[what]
        sel = (z > zb) & (z < zb + h)  # the row just above the layer bottom
        if not sel.any():
            continue
        val = -szz[sel].mean()
        ref_row = exact(a.surface - zb - 0.5 * h)
        rows.append((f"{name}, {what}", ref, ref_row, val, 100 * (val / ref_row - 1), -szz[sel].min(), -szz[sel].max()))
with open(os.path.join(a.result_dir, "geostatic.md"), "w") as f:
    f.write(f"# Geostatic state ({os.path.basename(snap)})\n\n")
    f.write("| where | paper (kPa) | gamma z at row (kPa) | Tamp row mean (kPa) | error | row range (kPa) |\n|---|---|---|---|---|---|\n")
    for n, ref, rr, v, e, lo, hi in rows:
        f.write(f"| {n} | {ref/1e3:.2f} | {rr/1e3:.2f} | {v/1e3:.2f} | {e:+.1f} % | {hi/1e3:.2f} to {lo/1e3:.2f} |\n")
    f.write("\n![vertical stress](vertical-stress.png)\n")
print(open(os.path.join(a.result_dir, "geostatic.md")).read())
