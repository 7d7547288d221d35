#!/usr/bin/python3
"""Checks of the main job's results page (scripts/make_results_page.py).

  check_results_page.py --self-test GENERATOR   build a synthetic output folder in a temporary
                                                directory, run GENERATOR on it and check the page
  check_results_page.py --page OUT_DIR          check an existing OUT_DIR/index.html (e.g. ./out
                                                after scripts/run_examples.sh)

A page passes when it parses, every relative src/href on it resolves to an existing file (after
percent-decoding), every PNG under OUT_DIR is shown as an <img>, and every example folder has a
section. Standard library only (Debian's /usr/bin/python3).
"""

import html.parser
import json
import os
import struct
import subprocess
import sys
import tempfile
import urllib.parse
import zlib


class Links(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.imgs, self.hrefs, self.ids, self.text = [], [], set(), []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            self.imgs.append(a.get("src", ""))
        if "href" in a:
            self.hrefs.append(a["href"])

    def handle_data(self, data):
        self.text.append(data)


def check_page(out_dir):
    """List of problems with out_dir/index.html (empty when it is fine)."""
    problems = []
    page = os.path.join(out_dir, "index.html")
    if not os.path.isfile(page):
        return ["%s does not exist" % page]
    p = Links()
    with open(page, encoding="utf-8") as f:
        p.feed(f.read())
    for url in p.imgs + p.hrefs:
        parsed = urllib.parse.urlsplit(url)
        if parsed.scheme or parsed.netloc:
            problems.append("absolute link %r (the page must only link relatively)" % url)
            continue
        if not parsed.path:  # '#anchor'
            if parsed.fragment and parsed.fragment not in p.ids:
                problems.append("anchor %r has no target" % url)
            continue
        target = os.path.normpath(os.path.join(out_dir, urllib.parse.unquote(parsed.path)))
        if not os.path.exists(target):
            problems.append("link %r does not resolve (%s)" % (url, target))
    shown = {os.path.normpath(os.path.join(out_dir, urllib.parse.unquote(u))) for u in p.imgs}
    for root, dirs, files in os.walk(out_dir):
        for f in files:
            if f.lower().endswith(".png"):
                path = os.path.normpath(os.path.join(root, f))
                if path not in shown:
                    problems.append("PNG %s is not shown on the page" % os.path.relpath(path, out_dir))
    for entry in os.listdir(out_dir):
        if os.path.isdir(os.path.join(out_dir, entry)) and entry not in p.ids:
            problems.append("example folder %s has no section" % entry)
    return problems


def tiny_png(path, w=4, h=3):
    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)
    raw = b"".join(b"\x00" + bytes([40, 90, 160] * w) for _ in range(h))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def make_synthetic(out):
    """An output folder like run_examples.sh leaves it, with the awkward cases in it."""
    slab = {"R": 0.2649123, "T": 0.3051, "R_stderr": 0.0004, "T_stderr": 0.0005, "paths": 1000000}
    write(os.path.join(out, "slab", "stdout.txt"), "R vs adding-doubling 0.26421\n" + json.dumps(slab) + "\n")
    write(os.path.join(out, "slab", "command.txt"), "build/release/bin/slab --paths 1000000 --out out/slab\n")
    write(os.path.join(out, "slab", "status.txt"), "ok 3\n")
    # Nested folders, a name with a space and a '#', and several PNGs.
    mf = os.path.join(out, "meng15_fig9_fluence")
    write(os.path.join(mf, "stdout.txt"), "glass: L1 (paper: agreement better at 15 mfp)\n"
          + json.dumps({"agreement_better_at_15_mfp": True, "photons": 1000, "l1": [0.07, 0.04]}) + "\n")
    write(os.path.join(mf, "command.txt"), "build/release/bin/meng15_fig9_fluence --quality quick\n")
    write(os.path.join(mf, "status.txt"), "ok 12\n")
    tiny_png(os.path.join(mf, "meng15_fig9_fluence.png"))
    tiny_png(os.path.join(mf, "sub dir", "glass #1.png"))
    write(os.path.join(mf, "fluence.csv"), "d,L1\n7.5,0.07\n")
    # A program the generator has no KEYS for, with nested JSON.
    write(os.path.join(out, "new_program", "stdout.txt"),
          json.dumps({"score": 1.5, "energy_r0.1": 0.25, "nested": {"a": [1, 2]}, "ok": True}) + "\n")
    write(os.path.join(out, "new_program", "status.txt"), "ok 1\n")
    tiny_png(os.path.join(out, "new_program", "plot.png"))
    # A failed program: no JSON on the last line.
    write(os.path.join(out, "guo21_fig3_extinction", "stdout.txt"), "starting\nsomething went wrong\n")
    write(os.path.join(out, "guo21_fig3_extinction", "status.txt"), "failed 1 2\n")
    # A PNG outside every example folder.
    tiny_png(os.path.join(out, "overview.png"))


def self_test(generator):
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out with space")
        make_synthetic(out)
        r = subprocess.run([sys.executable, generator, out, "--quality", "quick"], capture_output=True, text=True)
        if r.returncode != 0:
            return ["generator exited with %d: %s" % (r.returncode, r.stderr)]
        failures += check_page(out)
        with open(os.path.join(out, "index.html"), encoding="utf-8") as f:
            page = f.read()
        p = Links()
        p.feed(page)
        text = " ".join(p.text)
        # Key numbers from the JSON beside the paper's values, the command, the status.
        for needle in ["0.264912", "0.26421", "build/release/bin/slab --paths 1000000", "ok in 3 s",
                       "agreement better at 15 mfp", "true", "score", "1.5", "0.25",
                       "no JSON summary on the last stdout line", "failed 1 2"]:
            if needle not in text:
                failures.append("page text lacks %r" % needle)
        # Sections per paper, in the paper's section.
        for anchor in ["paper-meng15", "paper-foundation", "paper-guo21", "paper-other"]:
            if anchor not in p.ids:
                failures.append("no section %s" % anchor)
        if page.index('id="paper-meng15"') > page.index('id="meng15_fig9_fluence"'):
            failures.append("meng15_fig9_fluence is not inside the Meng15 section")
        if len(p.imgs) != 4:
            failures.append("expected 4 images on the page, found %d" % len(p.imgs))
        # The checker itself must catch a broken page: remove a PNG and an example folder's section.
        os.remove(os.path.join(out, "new_program", "plot.png"))
        os.makedirs(os.path.join(out, "late_program"))
        tiny_png(os.path.join(out, "late_program", "late.png"))
        broken = check_page(out)
        if not any("does not resolve" in b and "plot.png" in b for b in broken):
            failures.append("checker missed a dangling image link: %s" % broken)
        if not any("late.png is not shown" in b for b in broken):
            failures.append("checker missed an unshown PNG: %s" % broken)
        if not any("late_program has no section" in b for b in broken):
            failures.append("checker missed a folder without a section: %s" % broken)
    return failures


def main(argv):
    if len(argv) == 2 and argv[0] == "--self-test":
        failures = self_test(argv[1])
    elif len(argv) == 2 and argv[0] == "--page":
        failures = check_page(argv[1])
    else:
        print(__doc__, file=sys.stderr)
        return 2
    for f in failures:
        print("FAIL:", f)
    print("results page: %s" % ("ok" if not failures else "%d problem(s)" % len(failures)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
