"""Plot of examples/grain_stats (Meng15 Sec. 4.2.1): the scatterometer's phase function per
channel against the scattering angle. Usage: grain_stats.py CSV PNG TITLE (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import math
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png, title):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, c in (('p_r', 'r'), ('p_g', 'g'), ('p_b', 'b')):
        ax.semilogy(d['theta_deg'], [v / (2 * math.pi) for v in d[k]], color=c, label=k)
    ax.set_xlabel('scattering angle theta [deg]')
    ax.set_ylabel('Phi [1/sr]')
    ax.set_title(title + ': scatterometer phase function (Meng15 Sec. 4.2.1)')
    ax.legend()
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else 'grain')
