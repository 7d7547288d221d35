#!/usr/bin/python3
"""Write index.html into the main job's output folder: one section per paper and per example.

Usage: /usr/bin/python3 scripts/make_results_page.py OUT_DIR [--repo DIR] [--quality Q]

OUT_DIR holds one folder per example program, as scripts/run_examples.sh leaves it:
  OUT_DIR/<example>/stdout.txt    the program's stdout; its last line is the JSON summary
  OUT_DIR/<example>/command.txt   the command line that made it (one line)
  OUT_DIR/<example>/status.txt    "ok <seconds>" or "failed <exit code> <seconds>"
  OUT_DIR/<example>/**            PNG, EXR, CSV, JSON files the program wrote
Every PNG under OUT_DIR is shown on the page through a relative link (PNGs outside an example's
folder go into a last section), every other file is linked, and for each example the key numbers
of its JSON summary are put beside the paper's (or the reference's) values listed in KEYS below.
Standard library only, so it runs with Debian's /usr/bin/python3 on a fresh machine.
"""

import argparse
import datetime
import html
import json
import os
import re
import subprocess
import sys
import urllib.parse

# Papers in page order: key, citation, docs page (relative to the repository root).
SHORT = {"meng15": "Meng15", "guo21": "Guo21", "wang18": "Wang18", "moon07": "Moon07", "foundation": "foundation",
         "adapters": "adapters", "other": "other"}
PAPERS = [
    ("meng15", "Meng, Papas, Habel, Dachsbacher, Marschner, Gross, Jarosz 2015, "
               "Multi-Scale Modeling and Rendering of Granular Materials (ACM TOG 34(4))", "docs/meng15.md"),
    ("guo21", "Guo, Hu, Chen, Li, Guo, Yan 2021, "
              "Rendering Discrete Participating Media with Geometrical Optics Approximation", "docs/guo21.md"),
    ("wang18", "Wang & Holzschuch 2018, Point-Based Rendering for Homogeneous Participating Media "
               "with Refractive Boundaries (IEEE TVCG 24(10))", "docs/wang18.md"),
    ("moon07", "Moon, Walter & Marschner 2007, Rendering Discrete Random Media Using Precomputed "
               "Scattering Solutions (EGSR)", "docs/moon07.md"),
    ("foundation", "Foundation: transport theory checks, the volumetric path tracer, diffusion",
     "docs/foundation.md"),
    ("adapters", "Adapters: grainlight inside other renderers", "docs/architecture.md"),
]
# Programs whose name does not start with their paper's key.
PAPER_OF = {
    "packing": "meng15", "grain_stats": "meng15", "mie": "guo21",
    "slab": "foundation", "vpt_sphere_medium": "foundation", "diffusion_profiles": "foundation",
    "python_phase": "guo21", "ms_table": "wang18",
}
OTHER = ("other", "Other programs", None)

# Key numbers per example: (label, JSON path, paper / reference value, where that value is from).
# A JSON path is dotted keys and [index] steps, e.g. "mean_rgb[1]" or "a.b[0]". Values the JSON
# does not carry are shown as "n/a" (the page still renders); the printed comparison lines of the
# program's stdout are shown under the table as well.
KEYS = {
    "slab": [
        ("R (n = 1.4, a = 0.9, B = 2)", "R", "0.26421", "Prahl adding-doubling"),
        ("R std. error", "R_stderr", "", ""),
        ("T", "T", "0.30576", "Prahl adding-doubling"),
        ("T std. error", "T_stderr", "", ""),
    ],
    "vpt_sphere_medium": [
        ("mean radiance, green", "mean_rgb[1]", "0.2031 (docs/gallery.md, seed 1)", "bit-identical for any thread count"),
        ("samples per pixel", "spp", "64 at quick", "scene definition"),
        ("paths per second", "paths_per_second", "", ""),
    ],
    "diffusion_profiles": [
        ("R Monte Carlo (albedo 0.99, B = 4)", "R_mc", "reference", "Monte Carlo of the same slab"),
        ("R multipole, improved", "R_multipole_improved", "= R Monte Carlo", "d'Eon & Irving 2011 (Meng15 App. A)"),
        ("R multipole, classical", "R_multipole_classical", "= R Monte Carlo", "Donner & Jensen 2005"),
        ("R dipole (semi-infinite)", "R_dipole", "above the slab's R", "Jensen et al. 2001"),
        ("R improved dipole", "R_improved", "", ""),
        ("T multipole improved", "T_multipole_improved", "", ""),
        ("T Monte Carlo", "T_diffuse_mc", "", ""),
    ],
    "mie": [
        ("Qext (m = 1.33, x = 100)", "qext", "2.101 (m = 1.33 - 1e-5 i)", "MIEV0 test problems (Wiscombe 1979)"),
        ("Qsca", "qsca", "", ""),
        ("Qback", "qback", "", ""),
        ("g", "g", "0.8669 (m = 1.33 - 1e-5 i)", "MIEV0: g Qsca / Qsca = 1.821854 / 2.096594"),
    ],
    "guo21_ept_embree": [
        ("EPT in Embree / ours, equal spp, N = 1e6", "time_ratio_embree[1]", "2x", "Guo21 Fig. 20 (EPT in Mitsuba's BVH)"),
        ("EPT in Embree / ours, time to unit variance, N = 1e6", "ttuv_speedup_embree[1]", "", "measuring.md"),
        ("EPT through the grid / ours, equal spp, N = 1e6", "time_ratio_grid[1]", "", ""),
        ("EPT Embree vs grid, max |z|", "max_z_embree_vs_grid", "< 4 (same spheres)", "two lookups of one scene"),
    ],
    "embree_aggregate": [
        ("image mean, EPT over Embree (green)", "mean_embree", "= library EPT mean within the error",
         "render_ept on the same scene"),
        ("its standard error", "mean_embree_se", "", ""),
        ("image mean, library render_ept", "mean_library", "", "integrators/ept.hpp"),
        ("grains", "grains", "", ""),
        ("aggregate memory [MB]", "memory_mb", "O(1) in the grain count", "Meng15 Sec. 3.2"),
        ("rays per second (Embree queries)", "rays_per_second", "", ""),
    ],
    "python_phase": [
        ("size parameter x", "x", "", ""),
        ("Mie Qext", "qext", "-> 2 for large x", "extinction paradox"),
        ("Mie g", "g", "", ""),
        ("GOA Qext", "goa_qext", "Mie minus the edge term ~2 x^(-2/3)", "van de Hulst 1957"),
        ("phase function integral", "phase_integral", "1", "normalization"),
    ],
    "guo21_fig2_orders": [
        ("energy diff. p = 3 vs p = 100, r = 2 um", "energy_diff_p3_vs_p100_r2", "almost identical curves", "Guo21 Fig. 2"),
        ("energy diff., r = 10 um", "energy_diff_p3_vs_p100_r10", "almost identical", "Guo21 Fig. 2"),
        ("energy diff., r = 100 um", "energy_diff_p3_vs_p100_r100", "almost identical", "Guo21 Fig. 2"),
    ],
    "guo21_fig3_extinction": [
        ("RelMSE C_t p = 3 vs p = 1, r >= 1 um", "relmse_p3_vs_p1_r_ge_1", "< 1e-5", "Guo21 Sec. 6 / Fig. 3"),
        ("RelMSE C_t p = 3 vs p = 1, all r", "relmse_p3_vs_p1_all", "", ""),
        ("GOA vs Mie rel. deviation, r = 2 um", "goa_vs_mie_rel_dev_r2", "", ""),
        ("GOA vs Mie rel. deviation, r = 100 um", "goa_vs_mie_rel_dev_r100", "", ""),
    ],
    "guo21_fig4_amplitudes": [
        ("GOA vs Mie energy error, r = 1 um", "energy_r1", "discrepancies at 1 um", "Guo21 Fig. 4"),
        ("energy error, r = 10 um", "energy_r10", "good agreement for r > 1 um", "Guo21 Fig. 4"),
        ("energy error, r = 100 um", "energy_r100", "very good at 100 um", "Guo21 Fig. 4"),
        ("energy error, r = 0.1 um", "energy_r0.1", "large below 1 um", "Guo21 Fig. 4"),
    ],
    "guo21_fig6_error_runtime": [
        ("energy-weighted error, eta = 1.33, r = 2 um", "energy_err_eta133_r2", "< 0.01 for r >= 2 um", "Guo21 Fig. 6"),
        ("energy-weighted error, r = 5 um", "energy_err_eta133_r5", "< 0.01", "Guo21 Fig. 6"),
        ("energy-weighted error, r = 10 um", "energy_err_eta133_r10", "< 0.01", "Guo21 Fig. 6"),
        ("t_Mie / t_GOA, r = 100 um", "ratio_r100", "grows linearly with r", "Guo21 Fig. 6"),
        ("t_Mie / t_GOA, r = 1000 um", "ratio_r1000", "two orders of magnitude", "Guo21 Fig. 6"),
    ],
    "guo21_fig8_phase": [
        ("g, uniform 0.1-1 um", "g_uniform_0.1_1_550nm", "more forward-peaked as radii grow", "Guo21 Fig. 8"),
        ("g, uniform 1-10 um", "g_uniform_1_10_550nm", "", ""),
        ("g, uniform 10-100 um", "g_uniform_10_100_550nm", "", ""),
        ("g, log-normal 10 um, 2", "g_lognormal_10_2_550nm", "", ""),
    ],
    "guo21_fig11_diffraction_share": [
        ("diffraction share, r = 2 um", "total_share_r2", "about half (Babinet)", "Guo21 Fig. 11"),
        ("diffraction share, r = 1000 um", "total_share_r1000", "about half", "Guo21 Fig. 11"),
        ("diffraction half-angle [deg], r = 1000 um", "half_angle_deg_r1000", "confined near forward", "Guo21 Fig. 11"),
    ],
    "meng15_fig5_shape_of_grains": [
        ("grains", "grains", "millions to billions", "Meng15 Fig. 5"),
        ("memory [MB]", "memory_mb", "O(1) in the grain count", "Meng15 Sec. 4 / Alg. 1"),
        ("explicit instances would take [MB]", "explicit_memory_mb", "", ""),
        ("rays per second", "rays_per_second", "", ""),
    ],
    "meng15_fig6_packing_chords": [
        ("mean outer chord [R]", "mean_chord", "4R(1-f)/(3f) (Dixmier)", "Meng15 Fig. 6 top"),
        ("Dixmier mean chord [R]", "dixmier_mean_chord", "", "closed form"),
        ("chords < 0.1 R (measured)", "short_chord_fraction_measured", "", ""),
        ("chords < 0.1 R (exponential model)", "short_chord_fraction_dixmier", "", ""),
    ],
    "meng15_fig6_free_flight": [
        ("salt: mean free flight, TT", "salt_tt_mean", "= Eq. 4", "Meng15 Fig. 6 bottom"),
        ("salt: Eq. 4", "salt_eq4_mean", "", "Meng15 Eq. 4"),
        ("flour: TT", "flour_tt_mean", "= Eq. 4", "Meng15 Fig. 6 bottom"),
        ("flour: Eq. 4", "flour_eq4_mean", "", "Meng15 Eq. 4"),
        ("sand: TT", "sand_tt_mean", "= Eq. 4", "Meng15 Fig. 6 bottom"),
        ("sand: Eq. 4", "sand_eq4_mean", "", "Meng15 Eq. 4"),
    ],
    "meng15_halfspace_switch": [
        ("EPT reflectance, half-space of sand, 0 deg", "reflectance_ept", "", ""),
        ("VPT after 1 explicit interaction vs EPT", "rel_diff_vpt_k1", "Meng15's rule; sandcastle -6.8 %", "Meng15 Sec. 6"),
        ("VPT after 3 explicit interactions vs EPT", "rel_diff_vpt_k3", "within 3 %", "issue 12"),
        ("teleportation transport (Sec. 4.1) after 1, same switch point", "rel_diff_tt_entry_k1", "", "Meng15 Sec. 4.1"),
        ("TT from the exit point of interaction 1", "rel_diff_tt_exit_k1", "", ""),
    ],
    "meng15_fig6_ept_free_flight": [
        ("max rel. error of mean free path vs Eq. 4", "max_rel_mean_error", "EPT follows Eq. 4", "Meng15 Fig. 6 bottom"),
    ],
    "meng15_table1_grain_stats": [
        ("glass-bead: beta", "grains[0].beta", "1.00", "Meng15 Table 1"),
        ("glass-bead: lambda_s", "grains[0].lambda_s", "1.44", "Meng15 Table 1"),
        ("flour: beta", "grains[1].beta", "0.66", "Meng15 Table 1"),
        ("flour: lambda_s", "grains[1].lambda_s", "0.18", "Meng15 Table 1"),
        ("salt: beta", "grains[2].beta", "0.53", "Meng15 Table 1"),
        ("salt: lambda_s", "grains[2].lambda_s", "1.00", "Meng15 Table 1"),
        ("sand: beta", "grains[3].beta", "0.63", "Meng15 Table 1"),
        ("sand: lambda_s", "grains[3].lambda_s", "0.50", "Meng15 Table 1"),
        ("snow: beta", "grains[4].beta", "0.65", "Meng15 Table 1"),
        ("snow: lambda_s", "grains[4].lambda_s", "1.40", "Meng15 Table 1"),
        ("sugar: beta", "grains[5].beta", "0.71", "Meng15 Table 1"),
        ("sugar: lambda_s", "grains[5].lambda_s", "1.17", "Meng15 Table 1"),
        ("brown-sugar: beta", "grains[6].beta", "0.71", "Meng15 Table 1"),
        ("brown-sugar: lambda_s", "grains[6].lambda_s", "0.88", "Meng15 Table 1"),
    ],
    "ms_table": [
        ("orders >= 2, albedo 0.7: total", "total[0]", "1.633 (alpha^2 / (1 - alpha))", "closed form, infinite medium"),
        ("albedo 0.9: total", "total[1]", "8.1 (closed form; the box holds part)", "closed form"),
        ("albedo 0.99: captured by the box", "captured_fraction[2]", "", "light beyond +-10 mfp"),
        ("table MB (dense)", "table_mb", "8400 dense, 36-72 compressed", "Wang18 Table 2"),
        ("ranks", "ranks", "", ""),
    ],
    "grain_stats": [
        ("glass bead: beta", "beta", "1.00", "Meng15 Table 1 (glass beads)"),
        ("lambda_delta", "lambda_delta", "0.00", "Meng15 Table 1"),
        ("lambda_s", "lambda_s", "1.44", "Meng15 Table 1 (our ior 1.5 vs ~1.46)"),
        ("alpha_s", "alpha_s", "1.00", "Meng15 Table 1"),
        ("g", "g", "", ""),
    ],
    "meng15_fig9_fluence": [
        ("glass: L1(EPT, VPT) at 7.5 mfp", "glass-bead_L1_7_5", "", "Meng15 Fig. 9"),
        ("glass: L1 at 15 mfp", "glass-bead_L1_15", "smaller than at 7.5 mfp", "Meng15 Fig. 9"),
        ("snow: L1 at 7.5 mfp", "snow_L1_7_5", "", "Meng15 Fig. 9"),
        ("snow: L1 at 15 mfp", "snow_L1_15", "smaller than at 7.5 mfp", "Meng15 Fig. 9"),
        ("agreement better at 15 mfp", "agreement_better_at_15_mfp", "true", "Meng15 Fig. 9"),
    ],
    "meng15_hybrid_convergence": [
        ("speedup EPT+VPT (P_a = 1)", "ept_vpt_pa_1_speedup", "2.1-30x", "Meng15 Table 2"),
        ("speedup EPT+VPT+DA (P_a = 1)", "ept_vpt_da_pa_1_speedup", "up to 260x", "Meng15 Table 2"),
        ("speedup EPT+VPT (P_a optimal)", "ept_vpt_pa_opt_speedup", "2.2-101x", "Meng15 Table 2"),
        ("rel. difference EPT+VPT+DA vs EPT", "ept_vpt_da_pa_1_rel_diff", "0 within noise", "same image"),
        ("d_DA [R]", "d_DA", "", "Meng15 Sec. 5"),
    ],
    "packing": [
        ("fraction reached", "fraction", "0.63 requested", "Skoge et al. 2006 MD"),
        ("min centre distance / diameter", "min_center_distance_over_diameter", ">= 1 (no overlap)", "hard spheres"),
        ("mean chord", "mean_chord", "= Dixmier", ""),
        ("Dixmier mean chord", "dixmier_mean_chord", "", "closed form"),
    ],
    "wang18_point_based": [
        ("single scattering rel. diff. vs VPT", "rel_diff_single", "", "Wang18 Eq. 5 vs reference"),
        ("double scattering rel. diff.", "rel_diff_double", "", "Wang18 Eq. 6"),
        ("multiple scattering rel. diff.", "rel_diff_multiple", "", "Wang18 Eq. 7 (table)"),
        ("RMSE point-based vs VPT", "pb_error_rmse", "MSE 2.9e-4 .. 1.3e-3", "Wang18 Table 3"),
        ("speedup at equal error", "speedup_equal_error", "11x-360x vs UPBP", "Wang18 Table 3"),
    ],
    "wang18_surroundings": [
        ("object seen directly: rel. diff. vs VPT", "rel_diff_object_direct", "", "Wang18 Sec. 3.5.1"),
        ("object through the room: rel. diff.", "rel_diff_object_via_surroundings", "",
         "Wang18 Sec. 3.5.1 (camera rays after bounces)"),
        ("object light that entered after a room bounce (VPT share)", "vpt_object_lit_by_surroundings_share", "",
         "Wang18 Sec. 3.4.2 (not gathered)"),
    ],
    "moon07_shell_transport": [
        ("max MSD rel. difference shells vs explicit", "max_msd_rel_diff", "shells reproduce explicit paths",
         "Moon07 Sec. 5"),
        ("NMF error (rank used)", "nmf_error", "small at rank 5", "Moon07 Sec. 4"),
        ("speedup per path", "speedup", "", ""),
        ("direct: hits vs NEE", "direct_hits", "", ""),
        ("direct NEE", "direct_nee", "", ""),
    ],
}
# Stdout lines worth showing beside the table: the programs print the paper's values on them.
COMPARISON_LINE = re.compile(r"paper|table \d|eq\. ?\d|fig\. ?\d|\bvs\.?\b|reference|exact", re.IGNORECASE)
MAX_COMPARISON_LINES = 14
MAX_LINKED_FILES = 40


def paper_of(name):
    if name in PAPER_OF:
        return PAPER_OF[name]
    for key, _, _ in PAPERS:
        if name.startswith(key + "_") or name.startswith(key + "-"):
            return key
    if name.startswith("embree"):
        return "adapters"
    return OTHER[0]


def last_json(text):
    """The JSON object on the last non-empty line of text, or None."""
    for line in reversed(text.splitlines()):
        line = line.strip()
        if not line:
            continue
        try:
            value = json.loads(line)
        except ValueError:
            return None
        return value if isinstance(value, dict) else None
    return None


def lookup(obj, path):
    """Follow a path like 'a.b[2]' into nested dicts/lists; None when it is not there. A key that
    itself holds dots (e.g. "energy_r0.1") is matched whole first."""
    if isinstance(obj, dict) and path in obj:
        return obj[path]
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", path):
        if part.startswith("["):
            i = int(part[1:-1])
            if not isinstance(obj, list) or i >= len(obj):
                return None
            obj = obj[i]
        else:
            if not isinstance(obj, dict) or part not in obj:
                return None
            obj = obj[part]
    return obj


def fmt(value):
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "%.6g" % value
    if isinstance(value, list):
        shown = ", ".join(fmt(v) for v in value[:8])
        return "[" + shown + (", ..." if len(value) > 8 else "") + "]"
    if isinstance(value, dict):
        return "{...}"
    return str(value)


def href(out_dir, path):
    """Relative URL of a file under out_dir (percent-encoded, forward slashes)."""
    rel = os.path.relpath(path, out_dir).replace(os.sep, "/")
    return urllib.parse.quote(rel)


def read_text(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError:
        return None


def default_table(summary):
    """Up to 8 top-level scalar fields when an example has no KEYS entry."""
    rows = []
    for k, v in summary.items():
        if isinstance(v, (int, float, bool)) and len(rows) < 8:
            rows.append((k, k, "", ""))
    return rows


class Example:
    def __init__(self, out_dir, name):
        self.name = name
        self.dir = os.path.join(out_dir, name)
        stdout = read_text(os.path.join(self.dir, "stdout.txt")) or ""
        self.summary = last_json(stdout)
        self.comparison = [l.rstrip() for l in stdout.splitlines()[:-1] if COMPARISON_LINE.search(l)]
        self.command = (read_text(os.path.join(self.dir, "command.txt")) or "").strip()
        self.status = (read_text(os.path.join(self.dir, "status.txt")) or "").strip()
        self.pngs, self.files = [], []
        for root, dirs, files in os.walk(self.dir):
            dirs.sort()
            for f in sorted(files):
                p = os.path.join(root, f)
                (self.pngs if f.lower().endswith(".png") else self.files).append(p)


def collect(out_dir):
    examples, loose_pngs = [], []
    for entry in sorted(os.listdir(out_dir)):
        p = os.path.join(out_dir, entry)
        if os.path.isdir(p):
            examples.append(Example(out_dir, entry))
        elif entry.lower().endswith(".png"):
            loose_pngs.append(p)
    return examples, loose_pngs


def git_describe(repo):
    if not repo:
        return ""
    try:
        r = subprocess.run(["git", "-C", repo, "describe", "--always", "--dirty"], capture_output=True,
                           text=True, timeout=10)
        return r.stdout.strip() if r.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        return ""


CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1250px; color: #222; line-height: 1.35; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #468; padding-bottom: 0.2em; margin-top: 2em; }
h3 { margin-bottom: 0.3em; margin-top: 1.6em; }
.meta { color: #555; font-size: 0.9em; }
nav ul { columns: 3; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
td, th { border: 1px solid #bbb; padding: 0.2em 0.6em; text-align: left; vertical-align: top; }
th { background: #eef2f7; }
td.num { font-family: monospace; }
pre { background: #f5f5f5; padding: 0.5em; overflow-x: auto; font-size: 0.82em; white-space: pre-wrap; }
.figs { display: flex; flex-wrap: wrap; gap: 0.8em; }
figure { margin: 0; max-width: 400px; }
figure img { max-width: 400px; max-height: 320px; border: 1px solid #ccc; }
figcaption { font-size: 0.8em; color: #444; word-break: break-all; }
.ok { color: #070; font-weight: bold; } .failed { color: #b00; font-weight: bold; }
.files { font-size: 0.82em; }
"""


def render(out_dir, repo=None, quality=None):
    examples, loose_pngs = collect(out_dir)
    by_paper = {}
    for ex in examples:
        by_paper.setdefault(paper_of(ex.name), []).append(ex)
    sections = [p for p in PAPERS if p[0] in by_paper] + ([OTHER] if OTHER[0] in by_paper else [])

    e = html.escape
    o = []
    o.append("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
             "<title>grainlight results</title>\n<style>%s</style>\n</head>\n<body>\n" % CSS)
    o.append("<h1>grainlight: results of the main job</h1>\n")
    n_ok = sum(1 for ex in examples if ex.status.startswith("ok"))
    n_png = sum(len(ex.pngs) for ex in examples) + len(loose_pngs)
    meta = ["generated %s UTC" % datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M"),
            "%d example programs (%d ok), %d images" % (len(examples), n_ok, n_png)]
    if quality:
        meta.append("quality " + quality)
    commit = git_describe(repo)
    if commit:
        meta.append("commit " + commit)
    o.append("<p class=\"meta\">%s. Made by <code>scripts/run_examples.sh</code>; every number under "
             "&laquo;ours&raquo; is read from the last line (JSON) of the program's stdout.</p>\n"
             % e("; ".join(meta)))

    o.append("<nav><ul>\n")
    for key, title, _ in sections:
        o.append("<li><a href=\"#paper-%s\"><b>%s</b></a></li>\n" % (e(key), e(SHORT.get(key, key))))
        for ex in by_paper[key]:
            o.append("<li><a href=\"#%s\">%s</a></li>\n" % (e(ex.name), e(ex.name)))
    if loose_pngs:
        o.append("<li><a href=\"#loose\">other images</a></li>\n")
    o.append("</ul></nav>\n")

    o.append(overview(sections, by_paper))
    for key, title, doc in sections:
        o.append("<h2 id=\"paper-%s\">%s</h2>\n" % (e(key), e(title)))
        if doc and repo and os.path.exists(os.path.join(repo, doc)):
            o.append("<p class=\"meta\">Details: <a href=\"%s\">%s</a></p>\n"
                     % (href(out_dir, os.path.join(repo, doc)), e(doc)))
        for ex in by_paper[key]:
            o.append(render_example(out_dir, ex))
    if loose_pngs:
        o.append("<h2 id=\"loose\">Other images</h2>\n<div class=\"figs\">\n")
        for p in loose_pngs:
            o.append(figure(out_dir, p))
        o.append("</div>\n")
    o.append("</body>\n</html>\n")
    return "".join(o)


def overview(sections, by_paper):
    """One row per program: paper, status, time and its first key numbers beside the paper's."""
    e = html.escape
    o = ["<h2 id=\"overview\">Overview</h2>\n<table>\n<tr><th>program</th><th>paper</th><th>status</th>"
         "<th>key numbers: ours (paper / reference)</th></tr>\n"]
    for key, _, _ in sections:
        for ex in by_paper[key]:
            parts = ex.status.split()
            if ex.status.startswith("ok"):
                status = "<span class=\"ok\">ok</span>" + (" %s s" % e(parts[1]) if len(parts) > 1 else "")
            else:
                status = "<span class=\"failed\">%s</span>" % e(ex.status or "no status")
            cells = []
            if ex.summary is not None:
                rows = KEYS.get(ex.name)
                if rows is None:
                    rows = default_table(ex.summary)
                for label, path, ref, _ in [r for r in rows if r[2]][:2] or rows[:2]:
                    v = fmt(lookup(ex.summary, path))
                    cells.append("%s: <b>%s</b>%s" % (e(label), e(v), " (%s)" % e(ref) if ref else ""))
            o.append("<tr><td><a href=\"#%s\">%s</a></td><td>%s</td><td>%s</td><td>%s</td></tr>\n"
                     % (e(ex.name), e(ex.name), e(SHORT.get(key, key)), status, "<br>".join(cells)))
    o.append("</table>\n")
    return "".join(o)


def figure(out_dir, p):
    u = href(out_dir, p)
    cap = html.escape(os.path.relpath(p, out_dir))
    return ("<figure><a href=\"%s\"><img src=\"%s\" alt=\"%s\" loading=\"lazy\"></a>"
            "<figcaption>%s</figcaption></figure>\n" % (u, u, cap, cap))


def render_example(out_dir, ex):
    e = html.escape
    o = ["<section>\n<h3 id=\"%s\">%s</h3>\n" % (e(ex.name), e(ex.name))]
    if ex.status:
        cls = "ok" if ex.status.startswith("ok") else "failed"
        parts = ex.status.split()
        text = ("ok in %s s" % parts[1]) if cls == "ok" and len(parts) > 1 else ex.status
        o.append("<p>status: <span class=\"%s\">%s</span></p>\n" % (cls, e(text)))
    if ex.command:
        o.append("<pre><code>$ %s</code></pre>\n" % e(ex.command))
    rows = KEYS.get(ex.name)
    if rows is None and ex.summary:
        rows = default_table(ex.summary)
    if ex.summary is None:
        o.append("<p class=\"failed\">no JSON summary on the last stdout line</p>\n")
    elif rows:
        o.append("<table>\n<tr><th>quantity</th><th>JSON field</th><th>ours</th><th>paper / reference</th>"
                 "<th>source</th></tr>\n")
        for label, path, ref, src in rows:
            o.append("<tr><td>%s</td><td><code>%s</code></td><td class=\"num\">%s</td><td>%s</td><td>%s</td></tr>\n"
                     % (e(label), e(path), e(fmt(lookup(ex.summary, path))), e(ref), e(src)))
        o.append("</table>\n")
    if ex.comparison:
        shown = ex.comparison[:MAX_COMPARISON_LINES]
        more = len(ex.comparison) - len(shown)
        o.append("<p class=\"meta\">printed by the program (comparison lines of stdout):</p>\n<pre>%s%s</pre>\n"
                 % (e("\n".join(shown)), e("\n... (%d more lines in stdout.txt)" % more) if more > 0 else ""))
    if ex.pngs:
        o.append("<div class=\"figs\">\n")
        for p in ex.pngs:
            o.append(figure(out_dir, p))
        o.append("</div>\n")
    if ex.files:
        links = ["<a href=\"%s\">%s</a>" % (href(out_dir, p), e(os.path.relpath(p, ex.dir)))
                 for p in ex.files[:MAX_LINKED_FILES]]
        more = len(ex.files) - MAX_LINKED_FILES
        o.append("<p class=\"files\">files: %s%s</p>\n" % (", ".join(links),
                                                            " and %d more in the folder" % more if more > 0 else ""))
    if ex.summary is not None:
        o.append("<details><summary>JSON summary</summary><pre>%s</pre></details>\n"
                 % e(json.dumps(ex.summary, indent=1)))
    o.append("</section>\n")
    return "".join(o)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="the main job's output folder")
    ap.add_argument("--repo", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                    help="repository root (for the commit and the docs links)")
    ap.add_argument("--quality", default=None)
    args = ap.parse_args(argv)
    if not os.path.isdir(args.out):
        print("make_results_page: '%s' is not a folder" % args.out, file=sys.stderr)
        return 2
    page = render(args.out, repo=args.repo, quality=args.quality)
    target = os.path.join(args.out, "index.html")
    tmp = target + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(page)
    os.replace(tmp, target)
    print("make_results_page: wrote %s" % target, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
