#!/usr/bin/env python3
"""Writes docs/benchmarks.md, docs/reproduction.md and the plots in docs/images/ from the
outputs that scripts/benchmarks.sh leaves in its results folder, and from nothing else:
every measured number in the two documents is read from a command's output. The paper's
numbers are quoted from its tables (PAPER below, with their places in the paper).

  /usr/bin/python3 scripts/benchmarks_report.py --results build/benchmarks --docs docs

Python 3 standard library and matplotlib (Debian's python3-matplotlib).
"""
import argparse
import json
import re
import shutil
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MAP_MAX_BYTES = 300_000  # the maps' PNGs are kept in git: downscaled above this

# The paper: Nüchter, "Parallelization of Scan Matching for Robotic 3D Mapping", ECMR 2007
# (../shared/papers/ecmr2007_parallel_scan_matching.txt). Times in milliseconds, as printed,
# per thread count; None where the paper gives none.
PAPER = {
    "office": {
        "source": "Table I (Sec. VI-A: Kurt3D, office, closed loop)",
        "size": "11 scans x 85,000 points",
        "rows": [("ICP", {1: 12688, 2: 9821, 4: 9750}),
                 ("LUM", {1: 703, 2: 610, 4: 453}),
                 ("total", {1: 13391, 2: 10431, 4: 10203})],
    },
    "hannover": {
        "source": "Sec. VI-C (continuously acquired scans, Leibniz Universität Hannover)",
        "size": "468 scans x ~20,000 points",
        "rows": [("ICP", {1: None, 2: None, 4: None}),
                 ("LUM", {1: None, 2: None, 4: None}),
                 ("total", {1: 4526000, 2: None, 4: 3420000})],
    },
    "riegl": {
        "source": "Table II (Sec. VI-D: RIEGL scans of the main square in Horn)",
        "size": "11 scans x over 300,000 points",
        "rows": [("ICP", {1: 369828, 2: 218125, 4: 210515}),
                 ("LUM", {1: 794110, 2: 690023, 4: 678111}),
                 ("total", {1: 1163938, 2: 908148, 4: 888626})],
    },
}
# Table II's ICP rows for 2, 3 and 6 scans: the paper's "up to 48.2%" is the 3-scan row.
PAPER_RIEGL_ICP_PARTS = {2: {1: 20750, 2: 10985, 4: 10938},
                         3: {1: 41984, 2: 21750, 4: 21750},
                         6: {1: 134031, 2: 77390, 4: 77047}}

PRESETS = ["office", "riegl", "hannover", "kitti", "kitti-cv"]
PRESETS_2D = ["office2d", "hannover2d"]
LOGS_2D = ["intel", "fr079", "mit-csail"]
HANDHELD = ["handheld", "handheld-no-poses"]
PRESET_TITLES = {"office": "office", "riegl": "riegl", "hannover": "hannover",
                 "kitti": "kitti (odometry)", "kitti-cv": "kitti (no odometry)"}


# ---------------------------------------------------------------------------- reading

def read_kv(path):
    out = {}
    if path.exists():
        for line in path.read_text(errors="replace").splitlines():
            if "=" in line:
                k, v = line.split("=", 1)
                out[k.strip()] = v.strip()
    return out


def parse_blocks(text):
    """The bench's output as blocks: ("heading", level, text), ("table", header, rows) and
    ("text", line)."""
    blocks, table = [], None
    for raw in text.splitlines():
        line = raw.rstrip()
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if table is None:
                table = (cells, [])
            elif all(re.fullmatch(r":?-+:?", c) for c in cells if c):
                pass
            else:
                table[1].append(cells)
            continue
        if table is not None:
            blocks.append(("table",) + table)
            table = None
        if not line.strip():
            continue
        m = re.match(r"^(#+)\s+(.*)$", line)
        if m:
            blocks.append(("heading", len(m.group(1)), m.group(2)))
        else:
            blocks.append(("text", line.strip()))
    if table is not None:
        blocks.append(("table",) + table)
    return blocks


class Run:
    """One command of the run: NAME.txt, NAME.err, NAME.meta."""

    def __init__(self, results, name):
        self.name = name
        self.meta = read_kv(results / f"{name}.meta")
        txt = results / f"{name}.txt"
        self.text = txt.read_text(errors="replace") if txt.exists() else ""
        err = results / f"{name}.err"
        self.err = err.read_text(errors="replace") if err.exists() else ""
        self.blocks = parse_blocks(self.text)

    @property
    def ran(self):
        return bool(self.meta)

    @property
    def ok(self):
        return self.ran and self.meta.get("rc") == "0"

    def tables(self):
        return [(b[1], b[2]) for b in self.blocks if b[0] == "table"]

    def table(self, first_column):
        """The first table whose first header cell starts with first_column."""
        for header, rows in self.tables():
            if header and header[0].startswith(first_column):
                return header, rows
        return None


def number(cell):
    """The first number in a cell ("0.21 (1.00x)" -> 0.21), or None."""
    m = re.search(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", cell.replace(",", ""))
    return float(m.group(0)) if m else None


def column(header, name):
    for i, h in enumerate(header):
        if h == name or h.startswith(name):
            return i
    raise KeyError(name)


# ---------------------------------------------------------------------------- writing

def fmt_num(x, digits=3):
    if x is None:
        return "—"
    return f"{x:,.{digits}f}"


def fmt_paper(x):
    """A paper time in seconds as printed in milliseconds: 12688 ms -> 12.688, 4526000 -> 4,526."""
    if x is None:
        return "—"
    return f"{x:,.0f}" if x == int(x) else f"{x:,.3f}"


def saved(t1, tn):
    """The paper's speed-up in percent: the time saved against one thread."""
    if t1 is None or tn is None or t1 <= 0:
        return None
    return 100.0 * (1.0 - tn / t1)


def pct(x):
    return "—" if x is None else f"{x:+.1f} %".replace("+", "")


class Doc:
    def __init__(self):
        self.lines = []

    def add(self, *lines):
        self.lines.extend(lines)

    def para(self, text):
        self.lines.extend([text, ""])

    def table(self, header, rows):
        self.lines.append("| " + " | ".join(header) + " |")
        self.lines.append("|" + "---|" * len(header))
        for r in rows:
            self.lines.append("| " + " | ".join(str(c) for c in r) + " |")
        self.lines.append("")

    def code(self, text):
        self.lines.extend(["```", text, "```", ""])

    def text(self):
        out = "\n".join(self.lines).rstrip() + "\n"
        return re.sub(r"\n{3,}", "\n\n", out)


class Report:
    def __init__(self, results, docs):
        self.results = results
        self.docs = docs
        self.images = docs / "images"
        self.machine = read_kv(results / "machine.txt")
        self.quick = self.machine.get("mode") == "quick"
        self.runs = {}
        for meta in sorted(results.glob("*.meta")):
            self.runs[meta.stem] = Run(results, meta.stem)
        self.threads = [int(t) for t in self.machine.get("threads", "1").split(",") if t]

    def run(self, name):
        return self.runs.get(name) or Run(self.results, name)

    # -- common pieces

    def display_command(self, run):
        return run.meta.get("command", "")

    def machine_line(self, runs):
        m = self.machine
        runs = [r for r in runs if r.ran]
        when = ""
        if runs:
            start = runs[0].meta.get("start", "")
            end = runs[-1].meta.get("end", "")
            secs = sum(int(r.meta.get("seconds", "0")) for r in runs)
            when = f"; {start[:16]} to {end[11:16]} UTC, {secs} s"
            loads = f"; load average {runs[0].meta.get('load_before', '?')} before, " \
                    f"{runs[-1].meta.get('load_after', '?')} after (1, 5, 15 min)"
        else:
            loads = ""
        return (f"Machine: {m.get('cores', '?')} cores (`nproc`), {m.get('cpu', '?')}, "
                f"{m.get('memory_gib', '?')} GiB, {m.get('os', '?')}{loads}{when}.")

    def stamp(self, doc):
        m = self.machine
        if self.quick:
            doc.para("> **QUICK RUN** (`scripts/benchmarks.sh --quick`: one repeat per cell, "
                     "fewer workloads, on a machine that may have been busy). These numbers "
                     "validate the script, not the code: run `scripts/benchmarks.sh` on an "
                     "idle machine for the tables to quote.")
        doc.para(f"Generated by `scripts/benchmarks.sh` from the outputs of one run "
                 f"({m.get('date', '?')}, commit {m.get('commit', '?')}, thread counts "
                 f"{m.get('threads', '?')}, {m.get('repeats', '?')} timed repeat(s) a cell; "
                 f"{m.get('total', '?')} s of runs). Do not edit by hand: the script "
                 f"rewrites this file.")

    def emit_runs(self, doc, names, heading_level=3, missing=None):
        """The runs' commands, their machine line, and their output as printed."""
        runs = [self.run(n) for n in names]
        ran = [r for r in runs if r.ran]
        if not ran:
            doc.para(missing or "Not measured in this run.")
            return False
        doc.code("\n".join(self.display_command(r) for r in ran))
        doc.para(self.machine_line(ran))
        for r in ran:
            if not r.ok:
                tail = "\n".join(r.err.strip().splitlines()[-5:])
                doc.para(f"`{r.name}` failed (exit {r.meta.get('rc')}); its last error lines:")
                doc.code(tail or "(no output on stderr)")
            for b in r.blocks:
                if b[0] == "heading":
                    doc.add("#" * max(heading_level, b[1]) + " " + b[2], "")
                elif b[0] == "table":
                    doc.table(b[1], b[2])
                else:
                    doc.para(b[1])
        return True

    def image(self, doc, name, alt, relative="images"):
        if (self.images / name).exists():
            doc.para(f"![{alt}]({relative}/{name})")

    # -- plots

    def save(self, fig, name):
        self.images.mkdir(parents=True, exist_ok=True)
        fig.savefig(self.images / name, dpi=100)
        plt.close(fig)
        return name

    def plot_speedup(self):
        """Speed-up against threads: pICP's pairs, pLUM's bunny cases."""
        icp, lum = self.run("icp"), self.run("lum")
        series_icp, series_lum = {}, {}
        for header, rows in icp.tables():
            if not header or header[0] != "pair":
                continue
            try:
                ci, ct, cs = (column(header, "implementation"), column(header, "threads"),
                              column(header, "time [s]"))
            except KeyError:
                continue
            for r in rows:
                if "pICP" not in r[ci]:
                    continue
                mode = re.sub(r"\s*\(vs PCL.*\)", "", r[ci]).replace("pcl_parallel ", "")
                mode = re.sub(r"^pICP ?", "", mode) or "point-to-point"
                series_icp.setdefault(f"{r[0]}, {mode}", {})[int(r[ct])] = number(r[cs])
        t = lum.table("links")
        if t:
            header, rows = t
            c = column(header, "ours, default (symmetric pairs)")
            for r in rows:
                m = re.match(r"(\d+), (\d+) thread", r[0])
                if m:
                    series_lum.setdefault(f"one iteration, {m.group(1)} links",
                                          {})[int(m.group(2))] = number(r[c])
        t = lum.table("implementation")
        if t:
            header, rows = t
            c = column(header, "time [s]")
            for r in rows:
                m = re.match(r"ours, (.*), (\d+) thread\(s\)", r[0])
                if m:
                    series_lum.setdefault(f"whole relaxation, {m.group(1)}",
                                          {})[int(m.group(2))] = number(r[c])
        if not series_icp and not series_lum:
            return None
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
        for ax, series, title in ((axes[0], series_icp, "pICP (pcl_parallel_bench icp)"),
                                  (axes[1], series_lum, "pLUM (pcl_parallel_bench lum)")):
            top = max(self.threads)
            ax.plot([1, top], [1, top], "k--", lw=1, label="linear")
            for label, pts in sorted(series.items()):
                if 1 not in pts or not pts[1]:
                    continue
                xs = sorted(pts)
                ax.plot(xs, [pts[1] / pts[x] for x in xs], "o-", label=label)
            ax.set_xlabel("threads")
            ax.set_ylabel("speed-up over 1 thread")
            ax.set_title(title)
            ax.set_xticks(self.threads)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(self.plot_caption(), fontsize=8)
        fig.tight_layout()
        return self.save(fig, "speedup_threads.png")

    def plot_caption(self):
        m = self.machine
        q = "QUICK RUN, " if self.quick else ""
        return f"{q}{m.get('cores', '?')} cores, {m.get('cpu', '?')}, {m.get('date', '')}"

    def plot_icp_points(self):
        """ICP time per iteration against points: PCL, ours on 1 and N threads, Open3D."""
        icp = self.run("icp")
        t = icp.table("pair")
        if not t:
            return None
        points = {}
        panels = []
        for header, rows in icp.tables():
            if not header or header[0] != "pair":
                continue
            try:
                ci, ct, cm = (column(header, "implementation"), column(header, "threads"),
                              column(header, "ms / iteration"))
            except KeyError:
                continue
            has_points = "points src/tgt" in header
            series = {}
            for r in rows:
                if has_points:
                    points[r[0]] = number(r[column(header, "points src/tgt")])
                n = points.get(r[0])
                if n is None:
                    continue
                impl = r[ci]
                if impl.startswith("pcl::"):
                    label = f"PCL {impl.split('::')[-1]} (1 thread)"
                elif impl.lower().startswith("open3d"):
                    label = f"Open3D ({r[ct]} threads)"
                elif "estimated normals" in impl:
                    continue  # normals estimated inside align(): a different quantity
                else:
                    label = f"pcl_parallel pICP, {r[ct]} thread{'s' if r[ct] != '1' else ''}"
                series.setdefault(label, []).append((n, number(r[cm]), r[0]))
            panels.append(("point-to-point" if has_points else "point-to-plane (field normals)",
                           series))
        if not panels:
            return None
        fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.6), squeeze=False)
        for ax, (title, series) in zip(axes[0], panels):
            for label, pts in sorted(series.items()):
                pts.sort()
                ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
            if series:
                any_pts = sorted(next(iter(series.values())))
                for n, _, pair in any_pts:
                    ax.annotate(pair, (n, 0), xycoords=("data", "axes fraction"),
                                xytext=(0, 4), textcoords="offset points", fontsize=6,
                                rotation=90, ha="right")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("source points")
            ax.set_ylabel("ms per iteration")
            ax.set_title(f"ICP, {title}")
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=7)
        fig.suptitle(self.plot_caption(), fontsize=8)
        fig.tight_layout()
        return self.save(fig, "icp_time_per_iteration.png")

    def pslam(self, preset):
        """The pipeline's table of one preset: {threads: {column: seconds}}, errors, sizes."""
        run = self.run(f"pslam-{preset}")
        if not run.ok:
            return None
        t = run.table("threads")
        if not t:
            return None
        header, rows = t
        times = {}
        for r in rows:
            times[int(r[0])] = {h: number(c) for h, c in zip(header[1:], r[1:])}
        errors = {}
        e = run.table("poses")
        if e:
            eh, erows = e
            for r in erows:
                errors[r[0]] = {h: number(c) for h, c in zip(eh[1:], r[1:])}
        size = None
        for b in run.blocks:
            if b[0] == "text":
                m = re.match(r"(\d+) scans, (\d+) points \((\d+) per scan\)", b[1])
                if m:
                    size = (int(m.group(1)), int(m.group(3)))
                    break
        return {"times": times, "errors": errors, "size": size}

    def plot_pipeline(self):
        """Time per stage per preset, stacked, one bar per thread count."""
        data = [(p, self.pslam(p)) for p in PRESETS]
        data = [(p, d) for p, d in data if d]
        if not data:
            return None
        stages = [("read [s]", "read"), ("front end [s]", "front end (pICP)"),
                  ("loop det. [s]", "loop detection"), ("loop closing [s]", "loop closing (pLUM)")]
        colors = ["#bbbbbb", "#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"]
        fig, axes = plt.subplots(1, len(data), figsize=(max(7.0, 2.3 * len(data) + 1.5), 4.8),
                                 squeeze=False)
        for ax, (preset, d) in zip(axes[0], data):
            ths = sorted(d["times"])
            bottom = [0.0] * len(ths)
            for (col, label), color in zip(stages, colors):
                vals = [d["times"][t].get(col) or 0.0 for t in ths]
                ax.bar([str(t) for t in ths], vals, bottom=bottom, color=color, label=label)
                bottom = [b + v for b, v in zip(bottom, vals)]
            rest = [max(0.0, (d["times"][t].get("total [s]") or 0.0) - b)
                    for t, b in zip(ths, bottom)]
            ax.bar([str(t) for t in ths], rest, bottom=bottom, color=colors[4], label="other")
            n = d["size"]
            ax.set_title(f"{PRESET_TITLES[preset]}\n{n[0]} x {n[1] // 1000}k" if n
                         else PRESET_TITLES[preset], fontsize=9)
            ax.set_xlabel("threads")
            ax.grid(axis="y", alpha=0.3)
        axes[0][0].set_ylabel("seconds")
        handles, labels = axes[0][0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
        fig.suptitle("the pipeline's time per stage (pcl_parallel_bench pslam-PRESET)\n"
                     + self.plot_caption(), fontsize=8)
        fig.tight_layout(rect=(0, 0.07, 1, 1))
        return self.save(fig, "pipeline_stages.png")

    def copy_maps(self):
        """pcl_pslam's map.png per preset and 2D log (top view, trajectory in red)."""
        done = []
        for preset in PRESETS + PRESETS_2D + LOGS_2D + HANDHELD:
            src = self.results / f"map-{preset}" / "map.png"
            if not src.exists():
                src = self.results / f"log-{preset}" / "map.png"
            if not src.exists():
                continue
            dst = self.images / f"map_{preset}.png"
            self.images.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)
            step = 2
            while dst.stat().st_size > MAP_MAX_BYTES and step <= 8:
                img = plt.imread(src)
                plt.imsave(dst, img[::step, ::step])
                step *= 2
            done.append(preset)
        return done

    def plot_reproduction(self):
        """Time saved with more threads: the paper's rows against ours."""
        rows = self.reproduction_rows()
        if not rows:
            return None
        labels, paper2, paper4, ours = [], [], [], {}
        many = [t for t in self.threads if t > 1]
        for exp, stage, p, o in rows:
            if all(v is None for v in p.values()):
                continue  # the paper gives no time for this stage
            labels.append(f"{exp}\n{stage}")
            paper2.append(saved(p.get(1), p.get(2)))
            paper4.append(saved(p.get(1), p.get(4)))
            for t in many:
                ours.setdefault(t, []).append(saved(o.get(1), o.get(t)))
        bars = [("paper, 2 threads", paper2, "#aec7e8"), ("paper, 4 threads", paper4, "#1f77b4")]
        palette = ["#ff7f0e", "#d62728", "#8c564b", "#e377c2"]
        for i, t in enumerate(many):
            bars.append((f"ours, {t} threads", ours[t], palette[i % len(palette)]))
        width = 0.8 / len(bars)
        fig, ax = plt.subplots(figsize=(10, 4.4))
        for i, (label, vals, color) in enumerate(bars):
            xs = [k + (i - (len(bars) - 1) / 2) * width for k in range(len(labels))]
            ax.bar([x for x, v in zip(xs, vals) if v is not None],
                   [v for v in vals if v is not None], width, label=label, color=color)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(labels, fontsize=8)
        ax.set_ylabel("time saved against 1 thread [%]")
        ax.set_title("The paper's speed-up (Tables I, II, Sec. VI-C) and ours on the presets",
                     fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
        fig.suptitle(self.plot_caption(), fontsize=8, y=0.99)
        fig.tight_layout()
        return self.save(fig, "reproduction_speedup.png")

    # -- reproduction

    def ours_rows(self, preset):
        """Ours in the paper's rows: ICP = the front end, LUM = loop closing (pLUM), total
        = everything (reading and loop detection included). Seconds per thread count."""
        d = self.pslam(preset)
        if not d:
            return None, None
        col = {"ICP": "front end [s]", "LUM": "loop closing [s]", "total": "total [s]"}
        return {stage: {t: d["times"][t].get(c) for t in d["times"]}
                for stage, c in col.items()}, d

    def reproduction_rows(self):
        rows = []
        for exp in ("office", "hannover", "riegl"):
            ours, _ = self.ours_rows(exp)
            if not ours:
                continue
            for stage, paper in PAPER[exp]["rows"]:
                rows.append((exp, stage, {t: (v / 1000.0 if v is not None else None)
                                          for t, v in paper.items()}, ours[stage]))
        return rows

    def write_reproduction(self):
        doc = Doc()
        doc.add("# The paper's experiments, reproduced", "")
        self.stamp(doc)
        doc.para(
            "Nüchter, *Parallelization of Scan Matching for Robotic 3D Mapping*, ECMR 2007 "
            "(`../shared/papers/ecmr2007_parallel_scan_matching.txt`), times ICP and LUM on "
            "one, two and four threads in Table I (office), Sec. VI-C (Hannover) and Table II "
            "(RIEGL). The simulated presets of `sim/presets.h` are sized like those scan sets "
            "and come with the ground truth the paper's data lacked; `pcl_parallel_bench "
            "pslam-PRESET` maps each as `pcl_pslam run` does, at each thread count, and "
            "scores the poses against the truth.")
        doc.para(
            "Rows: the paper's ICP against our front end (pICP of each scan against a local "
            "map of the previous ones, including reducing the scan and its normals), the "
            "paper's LUM against our loop closing (pLUM relaxations), total against our "
            "whole run (reading the scans and loop detection included). Times in seconds "
            "(the paper's milliseconds divided by 1,000). In parentheses, the speed-up in "
            "percent as the paper reports it: the time saved against one thread, "
            "1 − t<sub>N</sub> / t<sub>1</sub>; negative where more threads took longer.")
        cmds = [self.display_command(self.run(f"pslam-{p}"))
                for p in ("office", "hannover", "riegl") if self.run(f"pslam-{p}").ran]
        if cmds:
            doc.para("Commands (each a part of `scripts/benchmarks.sh`, which regenerates "
                     "this file):")
            doc.code("\n".join(cmds))
            doc.para(self.machine_line([self.run(f"pslam-{p}")
                                        for p in ("office", "riegl", "hannover")]))
        for exp, title in (("office", "Office: Table I"), ("hannover", "Hannover: Sec. VI-C"),
                           ("riegl", "RIEGL: Table II")):
            doc.add(f"## {title}", "")
            ours, d = self.ours_rows(exp)
            paper = PAPER[exp]
            size = f"{d['size'][0]} scans x {d['size'][1]:,} points" if d and d["size"] else "?"
            doc.para(f"The paper: {paper['size']}, {paper['source']}. Ours: preset `{exp}`, "
                     f"{size}.")
            if not ours:
                doc.para(f"Preset `{exp}` was not measured in this run.")
                continue
            ths = sorted(d["times"])
            header = ["", "paper, 1 thread [s]", "2 threads", "4 threads"] + \
                     [f"ours, {t} thread{'s' if t > 1 else ''} [s]" for t in ths]
            rows = []
            for stage, p in paper["rows"]:
                p = {t: (v / 1000.0 if v is not None else None) for t, v in p.items()}
                cells = [{"ICP": "ICP (ours: front end)", "LUM": "LUM (ours: loop closing)",
                          "total": "total"}[stage],
                         "not given" if p[1] is None else fmt_paper(p[1])]
                for t in (2, 4):
                    cells.append("not given" if p[t] is None
                                 else f"{fmt_paper(p[t])} ({pct(saved(p[1], p[t]))})")
                o = ours[stage]
                for t in ths:
                    cells.append(fmt_num(o[t], 2) if t == 1
                                 else f"{fmt_num(o[t], 2)} ({pct(saved(o[1], o[t]))})")
                rows.append(cells)
            doc.table(header, rows)
            checks = [b[1] for b in self.run(f"pslam-{exp}").blocks
                      if b[0] == "text" and b[1].startswith(("Machine check", "Final poses"))]
            if checks:
                doc.para(" ".join(checks))
            err = d["errors"]
            if err:
                parts = []
                for which in ("odometry", "front end", "final"):
                    e = err.get(which)
                    if e:
                        parts.append(f"{which} {100 * e['ATE rmse [m]']:.2f} cm / "
                                     f"{e['ATE rot. rmse [deg]']:.3f}°")
                doc.para("ATE against the truth (RMSE after SE(3) alignment, translation / "
                         "rotation): " + ", ".join(parts) + ". The paper has no ground truth "
                         "for its data, so no such figure.")
            if exp == "riegl":
                parts = []
                for n, p in sorted(PAPER_RIEGL_ICP_PARTS.items()):
                    parts.append(f"{n} scans {pct(saved(p[1], p[2]))} on 2 threads, "
                                 f"{pct(saved(p[1], p[4]))} on 4")
                doc.para("Table II's ICP rows for the first scans: " + "; ".join(parts) +
                         " (the paper's \"up to 48.2%\" is the 3-scan row).")
            if exp == "office":
                p = dict(PAPER["office"]["rows"])["total"]
                doc.para(f"Sec. VI-A's \"reduced 76.2%\" is t<sub>4</sub> / t<sub>1</sub> of "
                         f"the total: {p[4]:,} / {p[1]:,} ms = {100 * p[4] / p[1]:.1f} %, i.e. "
                         f"{pct(saved(p[1], p[4]))} saved in the measure used here.")
        doc.add("## The maps", "")
        maps = [p for p in ("office", "hannover", "riegl") if (self.images / f"map_{p}.png").exists()]
        if maps:
            doc.para("`pcl_pslam demo --preset NAME` (the same presets, all cores; commands in "
                     "`docs/benchmarks.md`): the map's top view with the trajectory from the "
                     "green disc to the black ring, the errors against the truth in the "
                     "caption.")
            for p in maps:
                doc.para(f"![pcl_pslam demo --preset {p}](images/map_{p}.png)")
        if (self.images / "reproduction_speedup.png").exists():
            doc.add("## Speed-up side by side", "")
            doc.para("![time saved against one thread: the paper and ours]"
                     "(images/reproduction_speedup.png)")
        doc.add("## What differs", "")
        m = self.machine
        doc.para(
            f"- **Hardware.** Sec. VI-A and VI-D name the machine: an Intel Core Duo T2400, "
            f"1.83 GHz, two cores; the paper's four threads share those two cores. Here: "
            f"{m.get('cores', '?')} cores ({m.get('cpu', '?')}), thread counts "
            f"{m.get('threads', '?')}; a four-thread column appears when the script runs on "
            f"four cores or more.\n"
            f"- **Data.** The presets are simulations sized like the paper's sets (scan "
            f"count, points per scan, stop-and-go poses with drifting odometry), not the "
            f"paper's Kurt3D, Hannover or RIEGL scans; their ground truth gives the ATE.\n"
            f"- **Work.** The paper's text does not describe reducing the scans in these "
            f"experiments; the pipeline reduces each scan to one point per voxel before "
            f"matching (`-r`, by default the scans' median range / 20), matches it against a "
            f"local map with point-to-plane pICP and closes loops with pLUM on the reduced "
            f"points (docs/design.md). Its seconds are therefore not the paper's work on "
            f"faster hardware; the ratios between thread counts are what compares.\n"
            f"- **What does not scale.** Reading the scans is serial, and on small sets "
            f"(office: 11 scans) a stage lasts a fraction of a second, where starting threads "
            f"and other processes on the machine weigh more. The benchmark prints seconds to "
            f"two decimals, so the percentages of stages under a tenth of a second are "
            f"coarse; `docs/benchmarks.md` has each stage's times.")
        (self.docs / "reproduction.md").write_text(doc.text())

    # -- benchmarks.md

    def summary_rows(self):
        """One line per workload: ours against the reference on one thread, and the most
        threads against one, read from the tables below (ranges over the cases)."""
        top = max(self.threads)
        rows = []

        def rng(vals, digits=2):
            vals = [v for v in vals if v is not None]
            if not vals:
                return "—"
            lo, hi = min(vals), max(vals)
            return (f"{lo:.{digits}f}x" if f"{lo:.{digits}f}" == f"{hi:.{digits}f}"
                    else f"{lo:.{digits}f}-{hi:.{digits}f}x")

        kd = self.run("kdtree")
        t = kd.table("nearest neighbour")
        if t:
            h, r = t
            batch = {int(x[1]): x for x in r if x[0] == "KdTreeIndex::nearestBatch"}
            if 1 in batch:
                ratio = (number(batch[top][2]) / number(batch[1][2])
                         if top in batch and top != 1 else None)
                rows.append(["k-d tree: nearest-neighbour queries (`nearestBatch`, 1 thread) "
                             "vs `pcl::search::KdTree`", rng([number(batch[1][3])]),
                             rng([ratio])])
        t = kd.table("build")
        if t:
            h, r = t
            ours = {int(x[1]): number(x[2]) for x in r if x[0] == "pcl_parallel::KdTreeIndex"}
            pcl = [number(x[2]) for x in r if x[0].startswith("pcl::")]
            if 1 in ours and pcl:
                rows.append(["k-d tree: build", rng([pcl[0] / ours[1]]),
                             rng([ours[1] / ours[top]] if top in ours and top != 1 else [])])
        icp = self.run("icp")
        for header, r in icp.tables():
            if not header or header[0] != "pair":
                continue
            try:
                ci, ct = column(header, "implementation"), column(header, "threads")
                cp, c1 = column(header, "speed-up vs PCL"), column(header, "speed-up vs 1 thread")
            except KeyError:
                continue
            p2p = "points src/tgt" in header
            for label, keep in (("pICP point-to-point", lambda i: "pICP" in i) if p2p else
                                ("pICP point-to-plane, field normals",
                                 lambda i: "field normals" in i),):
                ours = [x for x in r if keep(x[ci])]
                vs_pcl = [number(x[cp]) for x in ours if x[ct] == "1"]
                vs_one = [number(x[c1]) for x in ours if x[ct] == str(top) and top != 1]
                n = len({x[0] for x in ours})
                rows.append([f"{label} ({n} pairs) vs PCL", rng(vs_pcl), rng(vs_one)])
        lum = self.run("lum")
        t = lum.table("links")
        if t:
            h, r = t
            try:
                cs, cd = column(h, "speed-up (same pairs)"), column(h, "ours, default")
                one = {x[0].split(",")[0]: x for x in r if ", 1 thread" in x[0]}
                many = {x[0].split(",")[0]: x for x in r if f", {top} thread" in x[0]}
                vs_one = [number(one[k][cd]) / number(many[k][cd]) for k in one
                          if k in many and top != 1]
                rows.append([f"pLUM one iteration, bunny ({', '.join(sorted(one))} links) vs "
                             "PCL's LUM, same pairs", rng([number(x[cs]) for x in one.values()], 0),
                             rng(vs_one)])
            except (KeyError, ZeroDivisionError, TypeError):
                pass
        t = lum.table("implementation")
        if t:
            h, r = t
            c = column(h, "time [s]")
            pcl = [number(x[c]) for x in r if x[0].startswith("PCL")]
            paper = {int(m.group(1)): number(x[c]) for x in r
                     for m in [re.match(r"ours, paper.*, (\d+) thread", x[0])] if m}
            if pcl and 1 in paper:
                rows.append(["pLUM whole relaxation, bunny (paper mode) vs PCL's LUM",
                             rng([pcl[0] / paper[1]]),
                             rng([paper[1] / paper[top]] if top in paper and top != 1 else [])])
        f = self.run("filters").table("voxel")
        if f:
            h, r = f
            try:
                ct, cv = column(h, "threads"), column(h, "vs PCL")
                rows.append(["voxel sampling vs `pcl::VoxelGrid` / `pcl::UniformSampling`",
                             rng([number(x[cv]) for x in r if x[ct] == "1"]), "—"])
            except KeyError:
                pass
        for preset in PRESETS:
            d = self.pslam(preset)
            if d and 1 in d["times"] and top in d["times"] and top != 1:
                rows.append([f"pipeline, preset {PRESET_TITLES[preset]}: total", "—",
                             rng([d["times"][1]["total [s]"] / d["times"][top]["total [s]"]])])
        return rows

    def write_benchmarks(self, plots, maps):
        doc = Doc()
        doc.add("# Benchmarks", "")
        self.stamp(doc)
        m = self.machine
        doc.para(f"Machine of this run: {m.get('cores', '?')} cores (`nproc`), "
                 f"{m.get('cpu', '?')}, {m.get('memory_gib', '?')} GiB, {m.get('os', '?')}, "
                 f"kernel {m.get('kernel', '?')}. Binaries: `{m.get('bench', '?')}`, "
                 f"`{m.get('pslam', '?')}`; data: `{m.get('data', '?')}`.")
        doc.para(
            "Each section gives the exact command, the machine line (load average before and "
            "after, from `/proc/loadavg`) and the command's output as printed. Where a table "
            "compares thread counts the benchmark adds a *machine check*: a compute-bound "
            "OpenMP loop timed on N threads against 1 before and after the table, N.00x on "
            "an idle machine and less when other processes hold cores. The thread counts "
            "default to 1, 2, 4, ... and `nproc`, so a run on a larger machine gives those "
            "columns. The paper's experiments side by side with ours: "
            "[`docs/reproduction.md`](reproduction.md).")
        rows = self.summary_rows()
        if rows:
            top = max(self.threads)
            doc.para("In short (speed-ups read from the tables below; ranges over their "
                     "cases; \"1 thread\" against the reference's one thread):")
            doc.table(["workload", "ours, 1 thread, vs the reference", f"{top} threads vs 1"],
                      rows)
        doc.para("Contents: [k-d tree](#k-d-tree) · [voxel sampling](#voxel-sampling) · "
                 "[ICP](#icp) · [LUM](#lum) · [contention](#contention-more-threads-beside-"
                 "other-processes) · [the pipeline](#pcl_pslam-the-mapping-pipeline-on-the-"
                 "presets) · [simulation](#simulation) · [memory](#memory) · [MPI](#mpi) · "
                 "[2D](#2d-the-presets-and-the-carmen-logs) · "
                 "[hand-held](#hand-held-a-2-hz-lidar) · "
                 "[loop closing](#loop-closing-against-the-papers-front-end) · "
                 "[Python](#python-the-gil-released) · [accuracy studies](#accuracy-studies)")

        doc.add("## k-d tree", "")
        doc.para(
            "`pcl_parallel::KdTreeIndex` and its PCL face `pcl_parallel::search::KdTree` "
            "against PCL's FLANN-backed `pcl::search::KdTree` (paper Sec. IV-A): build, "
            "nearest-neighbour throughput, the per-thread result slots padded to a cache "
            "line against packed (Sec. IV-B) and the bucket size.")
        self.emit_runs(doc, ["kdtree"])

        doc.add("## Voxel sampling", "")
        doc.para("`filters::voxelCentroid` against `pcl::VoxelGrid`, "
                 "`filters::voxelNearestToCentroid` against `pcl::UniformSampling`.")
        self.emit_runs(doc, ["filters"])

        doc.add("## ICP", "")
        doc.para(
            "`pcl::IterativeClosestPoint` (PCL 1.13) against `ParallelIterativeClosestPoint` "
            "(pICP, paper Sec. II and IV) on each thread count, and Open3D's "
            "`RegistrationICP` (point-to-point) when the benchmark is built with Debian's "
            "`libopen3d-dev` (optional; without it the output says so). The pairs "
            "(`apps/pcl_parallel_bench/bench_icp.cpp`):")
        doc.table(["pair", "input", "parameters"], [
            ["3dtk scan001->scan000", "`3dtk_dat`, range 50-3000 cm, full resolution",
             "odometry as guess, max distance 25 cm, 50 iterations, transformation epsilon 0 "
             "(PCL's default)"],
            ["bunny bun045->bun000", "`stanford_bunny` PLY, empty grid cells dropped",
             "guess = `bun.conf` perturbed by 3° / 5 mm, max distance 0.02 m, 50 iterations, "
             "epsilon 1e-10"],
            ["synthetic 300k", "300,000 points on the walls of a room with two boxes, 1 cm "
             "noise; the source an independent resampling, moved",
             "identity guess, max distance 0.3 m, 50 iterations, epsilon 1e-10"]])
        doc.para("\"time\" is the median of the timed repeats after one untimed warm-up, "
                 "\"best\" the fastest; \"vs PCL\" in the pICP rows is the rotation and "
                 "translation between pICP's and PCL's final transforms (units of the data). "
                 "Open3D stops by its own criteria (relative fitness and RMSE 1e-6, its "
                 "defaults; the same iteration limit), so its rows compare time to a similar, "
                 "not identical, stopping point.")
        self.emit_runs(doc, ["icp"])
        if "icp_time_per_iteration.png" in plots:
            doc.para("![ICP: ms per iteration against points, PCL and ours]"
                     "(images/icp_time_per_iteration.png)")
        if "speedup_threads.png" in plots:
            doc.para("![speed-up against threads, pICP and pLUM](images/speedup_threads.png)")

        doc.add("## LUM", "")
        doc.para("`ParallelLUM` (pLUM, paper Sec. V) against `pcl::registration::LUM`: one "
                 "iteration and the whole relaxation on the Stanford bunny, and the solve "
                 "step on synthetic graphs of growing size. The speed-up against threads is "
                 "in the plot of the ICP section.")
        self.emit_runs(doc, ["lum"])

        doc.add("## Contention: more threads beside other processes", "")
        doc.para("pICP, pLUM and the pipeline at 1 and N threads, idle, beside one "
                 "CPU-bound process pinned to one core, and beside N CPU-bound processes, on "
                 "the library's thread pool and on OpenMP (`PCL_PARALLEL_BACKEND=openmp`) in "
                 "the same process; docs/design.md (\"Threads\") has the why.")
        self.emit_runs(doc, ["contention"], missing=(
            "Not in the quick run (minutes): `scripts/benchmarks.sh` runs `pcl_parallel_bench "
            "contention --threads 1,N --repeats 1`." if self.quick else None))

        doc.add("## pcl_pslam: the mapping pipeline on the presets", "")
        doc.para(
            "`slam::Pipeline` end to end on each simulated preset: the preset is written in "
            "the app's formats, then each run streams it as `pcl_pslam run` does (read a "
            "scan, feed it) on each thread count. Per stage: reading, the front end "
            "(reduction, deskewing where the preset moves, pICP against the local map), loop "
            "detection, loop closing (pLUM); in parentheses the speed-up over the first "
            "thread count. Below each, the errors of the odometry, the front end and the "
            "final poses against the truth (ATE after SE(3) alignment; RPE as the KITTI "
            "devkit; evo's per-frame RPE).")
        names = [f"pslam-{p}" for p in PRESETS if self.run(f"pslam-{p}").ran]
        self.emit_runs(doc, names)
        if "pipeline_stages.png" in plots:
            doc.para("![the pipeline's time per stage per preset](images/pipeline_stages.png)")
        maps_3d = [p for p in maps if p in PRESETS]
        if maps_3d:
            cmds = [self.display_command(self.run(f"map-{p}")) for p in maps_3d]
            doc.para("The maps (`pcl_pslam demo`: top view, the trajectory from the green disc "
                     "to the black ring, the errors against the truth in the caption; the "
                     "README shows the office map):")
            doc.code("\n".join(cmds))
            for p in maps_3d:
                doc.para(f"![pcl_pslam demo --preset {p}](images/map_{p}.png)")

        self.write_2d(doc, maps)
        self.write_handheld(doc, maps)
        self.write_scan_to_scan(doc)

        doc.add("## Simulation", "")
        doc.para("Wall time to simulate each preset of `sim/presets.h` (ray casting, poses, "
                 "odometry; seed 1) on each thread count, and to write it in the app's "
                 "formats. One run a cell.")
        self.emit_runs(doc, ["sim"])

        doc.add("## Memory", "")
        doc.para("ICP's peak resident memory on uniform random clouds (each size in a forked "
                 "child; `getrusage` after the inputs exist and after `align()`, so \"ICP "
                 "adds\" is ICP's own peak on top of its input), and the k-d tree's bytes "
                 "(`KdTreeIndex::memoryBytes()`: nodes, its copy of the points in leaf order, "
                 "the ids) beyond the cloud it indexes.")
        self.emit_runs(doc, ["memory"], missing=(
            "Not in the quick run (ICP on 20 million points, a few GB): `scripts/benchmarks.sh` "
            "runs `pcl_parallel_bench memory --threads N`." if self.quick else None))

        doc.add("## MPI", "")
        self.write_mpi(doc)

        doc.add("## Python: the GIL released", "")
        doc.para("`apps/pcl_parallel_bench/python_gil.py`: how many Python-loop ticks the main "
                 "thread makes while `icp()` runs on another Python thread (a held GIL allows "
                 "about none), and two single-threaded `icp()` calls in turn against the same "
                 "two on two Python threads.")
        if not self.emit_runs(doc, ["python-gil"], missing=(
                "Not in this run: the script runs it when the Python module is built "
                "(`build/python`, or `--python-path DIR`). By hand:")):
            doc.code("PYTHONPATH=build/python /usr/bin/python3 "
                     "apps/pcl_parallel_bench/python_gil.py")

        doc.add("## Accuracy studies", "")
        doc.para("`pcl_parallel_bench accuracy` prints the accuracy studies that the tests "
                 "assert a part of: the bunny's pLUM convergence from several start draws "
                 "(`lum-seeds`), the real sequences (`real-car`: the mulran car drive's "
                 "keyframes predicted by their times and the pull-away from any start "
                 "keyframe) and the hannover preset without poses (`hannover-steps`).")
        self.emit_runs(doc, ["accuracy"], heading_level=4, missing=(
            "Not in this run (minutes): `scripts/benchmarks.sh --accuracy` adds it."))
        (self.docs / "benchmarks.md").write_text(doc.text())

    def write_mpi(self, doc):
        lum = sorted((n for n in self.runs if n.startswith("mpi-lum-")),
                     key=lambda n: [int(x) for x in re.findall(r"\d+", n)])
        pipe = [n for n in self.runs if n.startswith("mpi-pslam-") and n != "mpi-pslam-simulate"]
        if not lum and not pipe:
            doc.para("Not in this run: the script runs `pcl_parallel_mpi_bench` under "
                     "`mpirun` when both are there (not with `--no-mpi`).")
            return
        doc.para("`mpi::DistributedLUM` on the bunny: the case of \"LUM: Stanford bunny, "
                 "whole pLUM relaxation\" in paper mode (50 iterations), over ranks x threads "
                 "(`--bind-to none`). Rank 0's times; \"load\" reads the rank's scans. The "
                 "final poses are the same bits for every row (pose 9's translation).")
        runs = [self.run(n) for n in lum]
        doc.code("\n".join(self.display_command(r) for r in runs))
        doc.para(self.machine_line(runs))
        rows, base = [], None
        for r in runs:
            m = re.search(r"ranks (\d+) x threads (\d+): (\d+) links, (\d+) iterations, load "
                          r"([\d.]+) s, compute ([\d.]+) s \(([\d.]+) s/iteration\), (\d+) bytes",
                          r.text)
            if not m:
                rows.append([r.name, "failed (exit %s)" % r.meta.get("rc"), "", "", "", "",
                             "", ""])
                continue
            compute = float(m.group(6))
            if m.group(1) == "1" and m.group(2) == "1":
                base = compute
            ranks = re.findall(r"rank \d+: (\d+) scans, peak RSS (\d+) MiB", r.text)
            pose = re.search(r"pose 9 translation: (.*)", r.text)
            failed = "" if r.ok else f" (exit {r.meta.get('rc')})"
            rows.append([f"{m.group(1)} x {m.group(2)}{failed}", f"{compute:.2f}",
                         f"{base / compute:.2f}x" if base else "—", m.group(7), m.group(5), m.group(8),
                         ", ".join(f"{s} ({p} MiB)" for s, p in ranks),
                         pose.group(1) if pose else ""])
        doc.table(["ranks x threads", "compute [s]", "speed-up", "per iteration [s]",
                   "load [s]", "bytes sent per iteration", "scans held per rank (peak RSS)",
                   "pose 9 translation"], rows)
        if not pipe:
            return
        preset = re.search(r"^(\w+): \d+ scans", self.run(pipe[0]).text, re.M)
        preset = preset.group(1) if preset else "a"
        doc.para(f"`mpi::mapSegments`: the {preset} preset in segments, one per rank, each "
                 "mapped as the online pipeline maps a sequence, then loop closing over the "
                 "whole with the graph over the ranks. \"0 segments\" is the online pipeline "
                 "of one process, the baseline. Rank 0's times; \"waiting\" for the other "
                 "ranks' front ends.")
        runs = [self.run(n) for n in ["mpi-pslam-simulate"] + pipe]
        doc.code("\n".join(self.display_command(r) for r in runs))
        doc.para(self.machine_line(runs[1:]) + " The first command writes the preset, the "
                 "others read it.")
        rows, base = [], None
        for r in runs[1:]:
            m = re.search(r": (\d+) scans, (\d+) ranks x (\d+) threads, (\d+) segments: total "
                          r"([\d.]+) s \(([\d.]+) scans/s\); rank 0: read ([\d.]+) s, front end "
                          r"([\d.]+) s \+ ([\d.]+) s waiting, loop detection ([\d.]+) s, loop "
                          r"closing ([\d.]+) s", r.text)
            a = re.search(r"ATE front end ([\d.]+) cm, final ([\d.]+) cm; (\d+) loop links; sent "
                          r"outside pLUM ([\d.]+) MB \((\d+) scans point to point\); pLUM sends "
                          r"([\d.]+) kB", r.text)
            if not m or not a:
                rows.append([r.name, "failed (exit %s)" % r.meta.get("rc")] + [""] * 9)
                continue
            kept = re.findall(r"keeps (\d+) scans \(([\d.]+) MB\), peak RSS (\d+) MiB", r.text)
            total = float(m.group(5))
            if m.group(4) == "0" and m.group(2) == "1" and m.group(3) == "1":
                base = total
            speed = f" ({base / total:.2f}x)" if base else ""
            failed = "" if r.ok else f" (exit {r.meta.get('rc')})"
            rows.append([m.group(4), f"{m.group(2)} x {m.group(3)}{failed}", m.group(5) + speed,
                         m.group(6),
                         m.group(8), m.group(9), m.group(10), m.group(11),
                         f"{a.group(1)} / {a.group(2)}", f"{a.group(4)} MB ({a.group(5)})",
                         ", ".join(f"{k} ({mb} MB, {p} MiB)" for k, mb, p in kept)])
        doc.table(["segments", "ranks x threads", "total [s] (speed-up)", "scans/s", "front end [s]",
                   "waiting [s]", "loop det. [s]", "loop closing [s]",
                   "ATE front end / final [cm]", "sent outside pLUM (scans sent)",
                   "kept per rank: scans (MB, peak RSS)"], rows)

    def write_2d(self, doc, maps):
        """The 2D presets against their truth and the CARMEN logs against their durations."""
        doc.add("## 2D: the presets and the CARMEN logs", "")
        doc.para("The paper's 2D special case (Sec. VII): `pcl_pslam demo` on the 2D presets "
                 "(a horizontal 180-beam scanner on a robot with wheel odometry; the errors "
                 "against the truth) and `pcl_pslam run` on the three logs of "
                 "`../shared/data/radish_2d` as they come (scans kept where the robot moved "
                 "0.2 m or turned 10°). \"Recorded\" is the time from the first to the last "
                 "kept scan's stamp.")
        runs = [self.run(f"map-{p}") for p in PRESETS_2D] + [self.run(f"log-{log}")
                                                            for log in LOGS_2D]
        if not any(r.ran for r in runs):
            doc.para("Not measured in this run.")
            return
        doc.code("\n".join(self.display_command(r) for r in runs if r.ran))
        doc.para(self.machine_line(runs))
        def revisits(rep):
            c = rep.get("consistency")
            if not c:
                return "—"
            return (f"{c['conflicting']:,} of {c['revisits']:,} "
                    f"({c['front_end']['conflicting']:,})")

        rows = []
        for preset in PRESETS_2D:
            path = self.results / f"map-{preset}" / "report.json"
            if not path.exists():
                continue
            rep = json.loads(path.read_text())
            err = rep.get("errors_against_truth", {})
            cell = lambda k: (f"{err[k]['ate_m'] * 100:.1f} cm, {err[k]['ate_deg']:.2f}°"
                              if k in err else "—")
            rows.append([preset, str(len(rep["scans"])), cell("odometry"), cell("front_end"),
                         cell("final"), revisits(rep), f"{rep['total_seconds']:.1f}"])
        if rows:
            doc.table(["preset", "scans", "odometry ATE", "front end ATE", "final ATE",
                       "revisits disagreeing (front end)", "run [s]"], rows)
        runs = runs[len(PRESETS_2D):]
        rows = []
        for log, r in zip(LOGS_2D, runs):
            path = self.results / f"log-{log}" / "report.json"
            if not r.ok or not path.exists():
                rows.append([log, f"failed (exit {r.meta.get('rc')})"] + [""] * 5)
                continue
            rep = json.loads(path.read_text())
            stamps = [sc["stamp"] for sc in rep["scans"]]
            recorded, seconds = stamps[-1] - stamps[0], rep["total_seconds"]
            rows.append([log, str(len(stamps)), str(len(rep["loops"])), revisits(rep),
                         f"{seconds:.1f}", f"{recorded:.0f}", f"1/{recorded / seconds:.0f}"])
        doc.table(["log", "scans kept", "loop links", "revisits disagreeing (front end)",
                   "run [s]", "recorded [s]", "run / recorded"], rows)
        doc.para("\"Revisits disagreeing\": `report.json`'s `consistency`, the scans that came "
                 "back to an earlier one and put over 5 % of their points into the space it saw "
                 "through, or it into theirs (doubled walls, people), of all such pairs; in "
                 "brackets at the front end's poses.")
        for name in PRESETS_2D + LOGS_2D:
            if name in maps:
                doc.para(f"![{name}](images/map_{name}.png)")

    def write_handheld(self, doc, maps):
        """The handheld preset, with its odometry and without, against its truth."""
        doc.add("## Hand-held: a 2 Hz LiDAR", "")
        doc.para("`pcl_pslam demo --preset handheld`: a 32-beam LiDAR spinning at 2 Hz carried "
                 "through a split-level building, up one flight of stairs and down another, "
                 "looking round and tilting (0.5-1.1 m and up to 60° a sweep, each sweep skewed "
                 "by it), deskewed; with the simulated odometry and without any (`--no-poses`). "
                 "The worst step is the largest error of one consecutive step against the "
                 "truth's.")
        runs = [self.run(f"map-{h}") for h in HANDHELD]
        if not any(r.ran for r in runs):
            doc.para("Not measured in this run.")
            return
        doc.code("\n".join(self.display_command(r) for r in runs if r.ran))
        doc.para(self.machine_line(runs))
        rows = []
        for name, r in zip(HANDHELD, runs):
            path = self.results / f"map-{name}" / "report.json"
            if not r.ok or not path.exists():
                rows.append([name, f"failed (exit {r.meta.get('rc')})"] + [""] * 4)
                continue
            rep = json.loads(path.read_text())
            err = rep.get("errors_against_truth", {})
            ate = lambda k: (f"{err[k]['ate_m'] * 100:.1f} cm, {err[k]['ate_deg']:.2f}°"
                             if k in err else "—")
            worst = lambda k: (f"{err[k]['worst_step_m'] * 100:.1f} cm, "
                               f"{err[k]['worst_step_deg']:.2f}°" if k in err else "—")
            rows.append([name, ate("odometry"), ate("front_end"), ate("final"), worst("final"),
                         f"{rep['total_seconds']:.1f}"])
        doc.table(["run", "odometry ATE", "front end ATE", "final ATE", "worst step (final)",
                   "run [s]"], rows)
        for name in HANDHELD:
            if name in maps:
                doc.para(f"![{name}](images/map_{name}.png)")

    def write_scan_to_scan(self, doc):
        """Loop closing measured against a front end that drifts: the paper's pICP."""
        doc.add("## Loop closing against the paper's front end", "")
        doc.para("`pcl_pslam demo --preset P --scan-to-scan`: the front end matches each scan "
                 "against the one before (the paper's pICP, which drifts), loop closing "
                 "(pLUM) relaxes the whole; the errors against the truth of the front end's "
                 "poses and the final ones. \"Worst step\": the largest error of one "
                 "consecutive step; loop closing should not make it worse.")
        runs = [(p, self.run(f"s2s-{p}")) for p in PRESETS if p != "kitti-cv"]
        runs = [(p, r) for p, r in runs if r.ran]
        if not runs:
            doc.para("Not measured in this run.")
            return
        doc.code("\n".join(self.display_command(r) for _, r in runs))
        doc.para(self.machine_line([r for _, r in runs]))
        rows = []
        for preset, r in runs:
            path = self.results / f"s2s-{preset}" / "report.json"
            if not r.ok or not path.exists():
                continue
            err = json.loads(path.read_text()).get("errors_against_truth", {})
            if "front_end" not in err or "final" not in err:
                continue
            f, e = err["front_end"], err["final"]
            step = lambda x: f"{x['worst_step_m'] * 100:.2f} cm, {x['worst_step_deg']:.3f}°"
            rows.append([preset, f"{f['ate_m'] * 100:.2f} cm", f"{e['ate_m'] * 100:.2f} cm",
                         f"{f['ate_m'] / max(e['ate_m'], 1e-12):.1f}x", step(f), step(e)])
        doc.table(["preset", "front end ATE", "final ATE", "front end / final",
                   "worst step, front end", "worst step, final"], rows)

    def write(self):
        self.images.mkdir(parents=True, exist_ok=True)
        plots = [p for p in (self.plot_speedup(), self.plot_icp_points(), self.plot_pipeline(),
                             self.plot_reproduction()) if p]
        maps = self.copy_maps()
        self.write_benchmarks(plots, maps)
        self.write_reproduction()
        return plots, maps


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", default="build/benchmarks", type=Path)
    ap.add_argument("--docs", default="docs", type=Path)
    a = ap.parse_args()
    if not (a.results / "machine.txt").exists():
        sys.exit(f"benchmarks_report: {a.results}/machine.txt not found: run "
                 f"scripts/benchmarks.sh first")
    plots, maps = Report(a.results, a.docs).write()
    print(f"benchmarks_report: wrote {a.docs}/benchmarks.md, {a.docs}/reproduction.md, "
          f"{len(plots)} plots and {len(maps)} maps in {a.docs}/images/")


if __name__ == "__main__":
    main()
