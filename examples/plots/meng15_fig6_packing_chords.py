"""Plot of examples/meng15_fig6_packing_chords (Meng15 Fig. 6 top): measured outer chord lengths
vs Dixmier's exponential model. Usage: meng15_fig6_packing_chords.py CSV PNG MEAN (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png, mean):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(head)}
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(d['z_over_R'], d['measured_pdf'], label='Monte Carlo (MD packing, f = 0.63)')
    ax.plot(d['z_over_R'], d['dixmier_pdf'], '--', label='Dixmier (Meng15 Eq. 1)')
    ax.axvline(float(mean), color='k', lw=0.8, label='mean 4R(1-f)/(3f)')
    ax.set_xlabel('outer chord length z / R')
    ax.set_ylabel('p_b(z) R')
    ax.set_title('Meng15 Fig. 6 (top): outer chord lengths, f = 0.63')
    ax.legend()
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3])
