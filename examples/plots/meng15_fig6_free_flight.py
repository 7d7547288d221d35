"""Plot of examples/meng15_fig6_free_flight (Meng15 Fig. 6): top, outer chord lengths of the MD
packing vs Dixmier (Eq. 1); bottom, free flights of the teleportation-transport medium vs Eq. 4.
Usage: meng15_fig6_free_flight.py TOP_CSV PNG BOTTOM_CSV (Debian's /usr/bin/python3 with
matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}


def main(top_csv, png, bottom_csv):
    t = read_csv(top_csv)
    b = read_csv(bottom_csv)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6.5, 7))
    a1.plot(t['z'], t['p_b_measured'], 'k.', label='measured (MD packing)')
    a1.plot(t['z'], t['p_b_dixmier'], 'r-', label='Dixmier, Eq. 1')
    a1.set_xlabel('z / R')
    a1.set_ylabel('$p_b(z)$')
    a1.legend()
    a1.set_title('f = 0.63')
    for g, c in (('salt', 'C3'), ('flour', 'C0'), ('sand', 'C1')):
        a2.plot(b['z'], b[g + '_tt'], '.', color=c, label=g + ' TT medium')
        a2.plot(b['z'], b[g + '_eq4'], '-', color=c, label=g + ' Eq. 4')
    a2.set_xlabel('z / R')
    a2.set_ylabel('$p_t(z)$')
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3])
