#!/usr/bin/python3
"""Plots and a Markdown report for a Tamp drop-sequence (dynamic replacement) run.

    scripts/plot-dr.py RESULT_DIR [--lab data/lab-test.toml]

Reads what `tamp run` wrote to RESULT_DIR (blows.csv, column.csv, summary.json, tracers.csv,
pounder.csv, deck.toml, stages/*.h5) and writes there crater-depths.png, tracers.png,
column.png, pounder.png, column-forming.gif (one frame per stage) and report.md, which sets the Tamp column against the laboratory
ranges and the paper's LS-DYNA model (both from the lab file). Missing inputs (unfinished
run: no column.csv or summary.json; a tracers.csv without tracer columns) are skipped
with a note in the report.
"""
import argparse, glob, json, os, tomllib
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker

ap = argparse.ArgumentParser()
ap.add_argument("result_dir")
ap.add_argument("--lab", default=os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), "data", "lab-test.toml"), help="lab data TOML")
a = ap.parse_args()
D = a.result_dir
P = lambda name: os.path.join(D, name)
notes = []  # things skipped, listed in the report


def read_csv(name):
    """CSV with a header line -> dict of column name -> float array, or None if absent/empty."""
    if not os.path.exists(P(name)):
        notes.append(f"`{name}` is absent; what needs it is skipped.")
        return None
    d = np.genfromtxt(P(name), delimiter=",", names=True, ndmin=1)
    return {k: np.atleast_1d(d[k]) for k in d.dtype.names} if d.size else None


with open(a.lab, "rb") as f:
    lab = tomllib.load(f)
with open(P("deck.toml"), "rb") as f:
    deck = tomllib.load(f)
meas, ref = lab["measured"], lab["reference_model"]
sched = deck.get("schedule", {})
backfill_after = set(sched.get("backfill_after", []))
planned = len(sched.get("drop_heights", []))
lab_blows = len(lab["schedule"]["drop_heights"])
# Original ground level: schedule.ground_level, where 0 means the top of the blocks.
ground = sched.get("ground_level", 0.0) or max(b["z"][1] for b in deck["blocks"])
blows, column, pounder = read_csv("blows.csv"), read_csv("column.csv"), read_csv("pounder.csv")
tracers = read_csv("tracers.csv")
summary = None
if os.path.exists(P("summary.json")):
    summary = json.load(open(P("summary.json")))
else:
    notes.append("`summary.json` is absent (run unfinished?): column sizes are not compared; "
                 "uplift, aggregate and blows are taken from the last row of blows.csv.")
images = []

# 1. Crater depth and penetration per blow, backfilled blows marked ----------------------
if blows is not None:
    b = blows["blow"]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(b, 1e3 * blows["crater_depth_m"], "o-", label="crater depth at rest in contact")
    if "deepest_m" in blows:
        ax.plot(b, 1e3 * blows["deepest_m"], "v:", label="deepest point of the blow")
    if "crater_floor_m" in blows:
        ax.plot(b, 1e3 * blows["crater_floor_m"], "x", label="crater floor after extraction")
    ax.plot(b, 1e3 * blows["penetration_m"], "s--", label="penetration of the blow")
    for i, k in enumerate(sorted(x for x in backfill_after if x <= b.max())):
        ax.axvline(k, color="0.6", ls=":", lw=1, label="backfill after this blow" if i == 0 else None)
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_xlabel("blow"); ax.set_ylabel("mm"); ax.grid(alpha=0.3); ax.legend(fontsize=8)
    ax.set_title(f"{deck['run']['name']}: crater depth (below original ground) and penetration")
    fig.tight_layout(); fig.savefig(P("crater-depths.png"), dpi=120); plt.close(fig)
    images.append(("Crater depth and penetration per blow", "crater-depths.png"))

# 1b. Energy account per blow: where the energy the pounder brought went -------------------
if blows is not None and "energy_in_J" in blows:
    b = blows["blow"]
    e_in = blows["energy_in_J"]
    parts = [(k[len("plastic_"):-2] + " plastic work", blows[k]) for k in blows if k.startswith("plastic_")]
    parts += [("elastic (stored)", blows["elastic_J"]), ("artificial viscosity heat", blows["viscous_heat_J"]),
              ("contact (damping, friction)", blows["contact_J"]), ("radiated (boundary)", blows["radiated_J"]),
              ("damping (rest phase)", blows["damping_J"]), ("wall friction", blows["wall_friction_J"]),
              ("soil kinetic + potential", blows["soil_motion_J"])]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    bottom_pos, bottom_neg = np.zeros_like(e_in), np.zeros_like(e_in)
    for name, v in parts:
        f = 100 * v / e_in
        base = np.where(f >= 0, bottom_pos, bottom_neg)
        ax.bar(b, f, bottom=base, label=name, width=0.8)
        bottom_pos += np.where(f >= 0, f, 0)
        bottom_neg += np.where(f < 0, f, 0)
    ax.set_ylabel("% of the energy brought"); ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(f"{deck['run']['name']}: energy account of each blow (impact stage)")
    images_fed = "axis_images_J" in blows
    w = 0.4 if images_fed else 0.8
    ax2.bar(b - (0.2 if images_fed else 0), 100 * blows["residual_J"] / e_in, color="k", width=w, label="residual")
    if images_fed:  # a numerical source, counted as fed in (docs/sph.md, "Energy of the image pairs")
        ax2.bar(b + 0.2, 100 * (blows["axis_images_J"] + blows["wall_images_J"]) / e_in, color="tab:orange", width=w,
                label="fed in by the axis and wall images (numerical)")
        ax2.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax2.axhline(2, color="r", ls=":", lw=1); ax2.axhline(-2, color="r", ls=":", lw=1)
    ax2.set_ylabel("% of the blow"); ax2.set_xlabel("blow"); ax2.grid(alpha=0.3)
    ax2.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    fig.tight_layout(); fig.savefig(P("energy-account.png"), dpi=120); plt.close(fig)
    images.append(("Energy account per blow (below: the residual and the energy fed in by the mirror images; "
                   "+-2 % dotted)", "energy-account.png"))

# 2. Tracers: vertical displacement against time (paper Figs. 8 and 10) ---------------------
names = [k[:-5] for k in (tracers or {}) if k.endswith("_dz_m")]
if tracers is not None and not names:
    notes.append("`tracers.csv` has no tracer columns; tracers.png is not drawn.")
if names:
    fig, axs = plt.subplots(len(names), 1, figsize=(7, 2.6 * len(names)), sharex=True, squeeze=False)
    t = tracers["time_s"]
    starts = t[np.flatnonzero(np.diff(tracers["blow"]) > 0) + 1]  # first sample of each blow
    for ax, n in zip(axs[:, 0], names):
        ax.plot(t, 1e3 * tracers[n + "_dz_m"], lw=1)
        for s in starts:
            ax.axvline(s, color="0.7", ls=":", lw=0.8)
        ax.set_ylabel("dz, mm"); ax.set_title(f"tracer {n} (dotted: blow starts)", fontsize=9)
        ax.grid(alpha=0.3)
    axs[-1, 0].set_xlabel("simulated time, s")
    fig.tight_layout(); fig.savefig(P("tracers.png"), dpi=120); plt.close(fig)
    images.append(("Tracer vertical displacement (cf. paper Figs. 8, 10)", "tracers.png"))

# 3. Final particle state, mirrored section, with column outline and lab ranges ---------------
stages = sorted(glob.glob(P("stages/*.h5")))
if stages:
    import h5py
    with h5py.File(stages[-1], "r") as f:
        r, z, mat = (np.asarray(f["particles"][k]) for k in ("r", "z", "material"))
    mnames = [m["name"] for m in deck["materials"]]
    dx = deck["sph"]["spacing"]
    fig, ax = plt.subplots(figsize=(7, 6))
    for i, mn in enumerate(mnames):
        sel = mat == i
        agg = mn == deck.get("backfill", {}).get("material", "aggregate")
        ax.scatter(np.r_[r[sel], -r[sel]], np.r_[z[sel], z[sel]], s=5 if agg else 3,
                   c="k" if agg else f"C{i}", alpha=1 if agg else 0.5, lw=0, label=mn)
    if column is not None:
        zc = ground - column["depth_m"]
        ax.plot(column["diameter_m"] / 2, zc, "r-", lw=1.5, label="column outline (column.csv)")
        ax.plot(-column["diameter_m"] / 2, zc, "r-", lw=1.5)
        if "solid_diameter_m" in column:  # results from before 2026-12-05 have none
            ax.plot(column["solid_diameter_m"] / 2, zc, "r:", lw=1, label="solid diameter (aggregate volume)")
            ax.plot(-column["solid_diameter_m"] / 2, zc, "r:", lw=1)
    ax.axhline(ground, color="0.3", lw=0.8, ls="--", label="original ground")
    lo, hi = meas["column_max_diameter"]
    for s in (1, -1):  # lab max-diameter band on both sides
        ax.axvspan(s * lo / 2, s * hi / 2, color="g", alpha=0.15, label="lab max diameter" if s > 0 else None)
    lo, hi = meas["column_length"]
    ax.axhspan(ground - hi, ground - lo, color="orange", alpha=0.2, label="lab column base")
    lo, hi = meas["column_head_diameter"]
    ax.plot([-hi / 2, hi / 2], [ground, ground], "m-", lw=4, alpha=0.5, label="lab head diameter (max)")
    rlim = min(np.abs(r).max() + dx, 0.3)
    ax.set_xlim(-rlim, rlim); ax.set_aspect("equal"); ax.grid(alpha=0.2)
    ax.set_xlabel("r, m (mirrored)"); ax.set_ylabel("z, m")
    ax.set_title(f"final state: {os.path.basename(stages[-1])}", fontsize=9)
    ax.legend(fontsize=7, loc="lower right", markerscale=3)
    fig.tight_layout(); fig.savefig(P("column.png"), dpi=130); plt.close(fig)
    images.append(("Final particle state (aggregate in black) with lab ranges", "column.png"))
else:
    notes.append("No `stages/*.h5` snapshot; column.png is not drawn.")

# 3b. The column forming: one frame per stage file, as an animated GIF --------------------------
if stages and len(stages) > 1:
    import h5py
    from matplotlib.animation import PillowWriter
    pd = deck.get("pounder", {})
    mnames = [m["name"] for m in deck["materials"]]
    agg_name = deck.get("backfill", {}).get("material", "aggregate")
    frames = []
    for path in stages:
        with h5py.File(path, "r") as f:
            g = f["particles"]
            frames.append((os.path.basename(path), float(g.attrs["time"]),
                           *(np.asarray(g[k]) for k in ("r", "z", "material"))))
    rlim = min(max(np.abs(fr[2]).max() for fr in frames) + deck["sph"]["spacing"], 0.3)
    zs = np.concatenate([fr[3] for fr in frames])
    fig, ax = plt.subplots(figsize=(6, 5))
    writer = PillowWriter(fps=4)
    with writer.saving(fig, P("column-forming.gif"), dpi=80):
        ax.set_xlim(-rlim, rlim); ax.set_ylim(zs.min() - 0.02, ground + 0.15); ax.set_aspect("equal")
        fig.canvas.draw()
        # a particle drawn a spacing wide: points per metre of the axes, squared for scatter's area
        ppm = ax.get_window_extent().width * 72.0 / fig.dpi / (2 * rlim)
        size = (0.8 * deck["sph"]["spacing"] * ppm) ** 2
        for name, t, r, z, mat in frames:
            ax.clear()
            for i, mn in enumerate(mnames):
                sel = mat == i
                agg = mn == agg_name
                ax.scatter(np.r_[r[sel], -r[sel]], np.r_[z[sel], z[sel]], s=size,
                           c="k" if agg else f"C{i}", alpha=1 if agg else 0.6, lw=0, label=mn)
            # the pounder in the frames of its impact stages: its base where pounder.csv has it then
            if "impact" in name and pounder is not None and pd:
                k = int(np.searchsorted(pounder["time_s"], t, side="right")) - 1
                if k >= 0:
                    zb, hb, hm = pounder["base_z_m"][k], pd["base_diameter"] / 2, pd["max_diameter"] / 2
                    h = pd["height"]
                    xs = [-hb, hb, hm, hb, -hb, -hm, -hb]
                    ys = [zb, zb, zb + h / 2, zb + h, zb + h, zb + h / 2, zb]
                    ax.fill(xs, ys, color="0.55", alpha=0.8, lw=0, label="pounder")
            ax.axhline(ground, color="0.3", lw=0.8, ls="--", label="original ground")
            lo, hi = meas["column_length"]
            ax.axhspan(ground - hi, ground - lo, color="orange", alpha=0.2, label="lab column base")
            lo, hi = meas["column_max_diameter"]
            for sgn in (1, -1):
                ax.axvspan(sgn * lo / 2, sgn * hi / 2, color="g", alpha=0.12, label="lab max diameter" if sgn > 0 else None)
            ax.set_xlim(-rlim, rlim); ax.set_ylim(zs.min() - 0.02, ground + 0.15); ax.set_aspect("equal")
            ax.set_xlabel("r, m (mirrored)"); ax.set_ylabel("z, m")
            ax.set_title(f"{name[:-3]}  t = {t:.3f} s", fontsize=9)
            ax.legend(fontsize=6, loc="lower right", markerscale=min(1.0, 4.0 / np.sqrt(size)))
            writer.grab_frame()
    plt.close(fig)
    images.append((f"The column forming: {len(frames)} stages, one frame each (animated GIF)", "column-forming.gif"))

# 4. Pounder base height and acceleration -------------------------------------------------
if pounder is not None:
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    a1.plot(pounder["time_s"], pounder["base_z_m"], ".", ms=2)
    a1.axhline(ground, color="0.3", lw=0.8, ls="--"); a1.set_ylabel("base z, m")
    a2.plot(pounder["time_s"], pounder["a_z_m_s2"], ".", ms=2)
    a2.set_ylabel("a_z, m/s2 (up +)"); a2.set_xlabel("simulated time, s")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
    a1.set_title("pounder (dashed: original ground)", fontsize=9)
    fig.tight_layout(); fig.savefig(P("pounder.png"), dpi=120); plt.close(fig)
    images.append(("Pounder base height and acceleration", "pounder.png"))

# 5. Report -----------------------------------------------------------------------------------
def cmp(v, rng):
    """'yes' inside the range, else the relative error to the nearest end of it."""
    if v is None or rng is None:
        return "n/a"
    lo, hi = rng
    if lo <= v <= hi:
        return "yes (0 %)"
    end = lo if v < lo else hi
    return f"no: outside the range by {100 * abs(v - end) / end:.0f} % ({'below' if v < lo else 'above'})"


fmt = lambda v, k=1e3, d=0: "n/a" if v is None else f"{k * v:.{d}f}"
S = summary or {}
last = {k: v[-1] for k, v in blows.items()} if blows is not None else {}
uplift = S.get("uplift_m", last.get("uplift_m"))
agg = S.get("aggregate_total_kg", float(blows["aggregate_added_kg"].sum()) if blows is not None else None)
# counts are numbers in summary.json (1552.0): shown as whole numbers
count = lambda x: str(int(round(x))) if isinstance(x, (int, float)) and x == x else str(x)
done = int(round(S.get("blows_completed", len(blows["blow"]) if blows is not None else 0)))
c11 = ref["column_after_11_charges"]
mm = lambda x: f"{1e3 * x[0]:.0f}-{1e3 * x[1]:.0f}"
rows = [
    ("column length, mm", fmt(S.get("column_length_m")), mm(meas["column_length"]), "n/a",
     cmp(S.get("column_length_m"), meas["column_length"])),
    ("head diameter, mm", fmt(S.get("head_diameter_m")), mm(meas["column_head_diameter"]),
     fmt(c11["head_diameter"]), cmp(S.get("head_diameter_m"), meas["column_head_diameter"])),
    ("max diameter, mm", fmt(S.get("max_diameter_m")), mm(meas["column_max_diameter"]),
     fmt(c11["max_diameter"]), cmp(S.get("max_diameter_m"), meas["column_max_diameter"])),
    ("base diameter, mm", fmt(S.get("base_diameter_m")), "n/a", fmt(c11["base_diameter"]), "n/a"),
    ("uplift beside column, mm", fmt(uplift, d=1), mm(meas["uplift_next_to_column"]),
     fmt(ref["uplift"]), cmp(uplift, meas["uplift_next_to_column"])),
    ("aggregate total, kg", fmt(agg, 1, 2),
     f"{meas['test2_aggregate_mass']:.2f}-{meas['test1_aggregate_mass']:.2f}", "n/a",
     cmp(agg, sorted([meas["test2_aggregate_mass"], meas["test1_aggregate_mass"]]))),
    (f"blows completed (of {planned} in the deck)", str(done), f"{lab_blows} (all)",
     str(ref["blows_completed"]), "n/a"),
]
L = [f"# Dynamic replacement run: {deck['run']['name']}", ""]
if summary:
    L += [f"Deck `{deck['run']['name']}`: {count(S['particles'])} particles, spacing {1e3 * S['spacing_m']:g} mm, "
          f"{count(S['blows_completed'])} of {planned} blows completed, {count(S['steps'])} steps, "
          f"{S['simulated_time_s']:.3f} s simulated in {S['wall_s']:.1f} s wall time.", ""]
else:
    L += [f"Deck `{deck['run']['name']}`: run unfinished (no summary.json); "
          f"{done} of {planned} blows in blows.csv.", ""]
if done < lab_blows:
    L += [f"The run covers {done} of the {lab_blows} laboratory blows, so its column is not the "
          "finished laboratory column; the comparison below is of an incomplete column.", ""]
L += ["## Tamp against the laboratory tests and the paper's LS-DYNA model", "",
      "LS-DYNA column sizes are after 11 charges (22 blows), where that model stopped. "
      "Errors are relative to the nearest end of the lab range.", "",
      "| quantity | Tamp | lab measured (range) | paper LS-DYNA | inside lab range? |",
      "|---|---|---|---|---|"]
L += ["| " + " | ".join(row) + " |" for row in rows]
L += ["", "The laboratory crater depths after each blow (paper Fig. 2) are not tabulated, "
      "so they are not compared here.", ""]
if blows is not None:
    has = "deepest_m" in blows
    L += ["## Per blow", "", "| blow | H, m | crater depth at rest, mm | deepest, mm | floor after extraction, mm | "
          "penetration, mm | contacts | restitution | peak deceleration, m/s2 | uplift, mm | aggregate added, kg | "
          "energy in, J | energy residual, % | fed in by the axis images, % | backfill after |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    g = lambda k, i, s=1e3, d=1: f"{s * blows[k][i]:.{d}f}" if k in blows else "n/a"
    for i in range(len(blows["blow"])):
        k = int(blows["blow"][i])
        res = (f"{100 * blows['residual_J'][i] / blows['energy_in_J'][i]:+.2f}" if "residual_J" in blows else "n/a")
        img = (f"{100 * blows['axis_images_J'][i] / blows['energy_in_J'][i]:+.2f}" if "axis_images_J" in blows else "n/a")
        L.append(f"| {k} | {blows['drop_height_m'][i]:.2f} | {1e3 * blows['crater_depth_m'][i]:.1f} | "
                 f"{g('deepest_m', i)} | {g('crater_floor_m', i)} | "
                 f"{1e3 * blows['penetration_m'][i]:.1f} | {g('contacts', i, 1, 0)} | {g('restitution', i, 1, 3)} | "
                 f"{blows['peak_deceleration_m_s2'][i]:.0f} | "
                 f"{1e3 * blows['uplift_m'][i]:.1f} | {blows['aggregate_added_kg'][i]:.2f} | "
                 f"{g('energy_in_J', i, 1, 1)} | {res} | {img} | {'yes' if k in backfill_after else ''} |")
    if has and "rest_in_contact" in blows and (blows["rest_in_contact"] < 1).any():
        bad = [int(x) for x, r in zip(blows["blow"], blows["rest_in_contact"]) if r < 1]
        L += ["", f"Blows {bad} did not come to rest in contact within max_impact_time (recorded as they stood)."]
    if "residual_J" in blows:
        over = [int(x) for x, r, e in zip(blows["blow"], blows["residual_J"], blows["energy_in_J"]) if abs(r) > 0.02 * e]
        L += ["", "Energy residual above 2 % of the energy brought: " + (f"blows {over}" if over else "none") +
              " (docs/drop-sequence.md, Energy account)."]
    if "axis_images_J" in blows:
        fed = [(int(x), 100 * a / e) for x, a, e in zip(blows["blow"], blows["axis_images_J"], blows["energy_in_J"])
               if abs(a) > 0.02 * e]
        L += ["", "Energy fed in (or taken out, < 0) by the pairs with the axis images above 2 % of the energy "
              "brought, a numerical error of the axis treatment counted in the account (docs/sph.md, \"Energy of the "
              "image pairs\"): " + (", ".join(f"blow {k} {p:+.1f} %" for k, p in fed) if fed else "none") + "."]
    L.append("")
if notes:
    L += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
L += ["## Figures", ""] + [f"![{cap}]({png})\n" for cap, png in images]
open(P("report.md"), "w").write("\n".join(L))
print(f"wrote {P('report.md')} and {len(images)} figures")
