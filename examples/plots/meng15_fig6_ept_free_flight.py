"""Plot of examples/meng15_fig6_ept_free_flight (Meng15 Fig. 6 bottom): free flights measured by
explicit path tracing of grains vs Eq. 4's exponential, with both means as vertical lines.
Usage: meng15_fig6_ept_free_flight.py CSV PNG GRAIN:EPT_MEAN:EQ4_MEAN ... (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png, means_args):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    b = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    means = {}
    for a in means_args:
        g, me, ma = a.split(':')
        means[g] = (float(me), float(ma))
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for g, c in (('salt', 'C3'), ('flour', 'C0'), ('sand', 'C1')):
        ax.plot(b['z'], b[g + '_ept'], '.', color=c, label=g + ' EPT')
        ax.plot(b['z'], b[g + '_eq4'], '-', color=c, label=g + ' Eq. 4')
        if g in means:
            me, ma = means[g]
            ax.axvline(me, color=c, ls=':')
            ax.axvline(ma, color=c, ls='--')
    ax.set_xlabel('z / R')
    ax.set_ylabel('$p_t(z)$')
    ax.set_title('f = 0.63, EPT vs Eq. 4 (means: dotted EPT, dashed Eq. 4)')
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
