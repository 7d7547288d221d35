"""Panel of examples/wang18_fig20_vs_shells (Wang18 Fig. 20): the multiple-scattering term of the
bumpy sphere from the MS table, from shells of the same memory and of more memory, and the VPT's,
with memory, relative difference and high-pass ratio in the titles; below, the representations
(MS table (rho, z) slice and lobe, the shells' exit-direction densities).
Usage: wang18_fig20_vs_shells.py CSV PNG OUTDIR (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import os
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png, out):
    with open(csv_path) as f:
        rows = {r['method']: r for r in csv.DictReader(f)}
    fig, axes = plt.subplots(2, 4, figsize=(13, 7))
    top = [('table', 'MS table (ours)'), ('shells_equal', 'shells, same memory'),
           ('shells_large', 'shells, more memory'), ('vpt', 'VPT reference')]
    for ax, (key, label) in zip(axes[0], top):
        ax.imshow(mpimg.imread(os.path.join(out, f'wang18_fig20_{key}_multiple.png')))
        if key in rows:
            r = rows[key]
            label += (f"\n{float(r['memory_mb']):.2f} MB, {100 * float(r['rel_diff']):+.1f}%,"
                      f" hp ratio {float(r['highpass_ratio']):.2f}")
        ax.set_title(label, fontsize=9)
        ax.axis('off')
    bottom = [('table_slice', 'table: emission over (rho, z)'), ('table_lobe', 'table: lobe (theta x phi)'),
              ('shells_equal_exit', 'shells same memory: exit dir. (u, v)'),
              ('shells_large_exit', 'shells more memory: exit dir. (u, v)')]
    for ax, (key, label) in zip(axes[1], bottom):
        ax.imshow(mpimg.imread(os.path.join(out, f'wang18_fig20_repr_{key}.png')), interpolation='nearest')
        ax.set_title(label, fontsize=9)
        ax.axis('off')
    fig.suptitle('Wang18 Fig. 20: multiple scattering, MS table vs Moon07 shells (bumpy sphere, g = 0.95)')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3])
