"""Plot of examples/mie: |S1| and |S2| against the scattering angle (log scale).
Usage: mie.py CSV PNG TITLE (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png, title):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(head)}
    s1 = [(a * a + b * b) ** 0.5 for a, b in zip(d['re_S1'], d['im_S1'])]
    s2 = [(a * a + b * b) ** 0.5 for a, b in zip(d['re_S2'], d['im_S2'])]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.semilogy(d['theta_deg'], s1, label='|S1|')
    ax.semilogy(d['theta_deg'], s2, label='|S2|')
    ax.set_xlabel('scattering angle [deg]')
    ax.legend()
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3])
