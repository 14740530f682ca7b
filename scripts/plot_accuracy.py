#!/usr/bin/python3
"""Plots bench_accuracy's CSV: the paper's Fig. 2 (mean reprojection and relative focal error against image noise),
the outlier and number-of-lines experiments. Usage: plot_accuracy.py DIR (reads DIR/accuracy.csv, writes DIR/*.png)."""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LABELS = {
    "dlt_points_unnormalised": "DLT-Points, unnormalised",
    "dlt_points": "DLT-Points, normalised",
    "dlt_lines": "DLT-Lines (paper, linear)",
    "dlt_lines_finetuned": "DLT-Lines, fine-tuned lines",
    "dlt_lines_finetuned_refined": "DLT-Lines, fine-tuned lines, RANSAC + refinement",
    "dlt_lines_refined": "DLT-Lines + RANSAC + refinement",
    "combined_refined": "lines + end points, RANSAC + refinement",
    "opencv_calibrate_camera": "OpenCV calibrateCamera (end points)",
    "oracle_inliers_refined": "oracle: only the good lines, refined",
    "calibrate_lines_default": "calibrate_lines defaults (plumb-line stage, joint error model)",
    "previous_defaults": "before issue 13 (DLT over parts, image residuals)",
}


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    means = defaultdict(lambda: defaultdict(list))  # (experiment, method) -> x -> [(focal, reprojection)]
    with open(out + "/accuracy.csv") as f:
        for row in csv.DictReader(f):
            if row["ok"] != "1":
                continue
            means[(row["experiment"], row["method"])][float(row["x"])].append(
                (100.0 * float(row["focal_rel"]), float(row["reprojection_px"])))

    def plot(experiment, xlabel, filename, logx=False, skip_zero=False):
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
        for (exp, method), by_x in sorted(means.items()):
            if exp != experiment:
                continue
            # Noise-free errors (1e-10) would flatten the log scale; the table has them.
            xs = sorted(x for x in by_x if not (skip_zero and x == 0.0))
            focal = [sum(v[0] for v in by_x[x]) / len(by_x[x]) for x in xs]
            reprojection = [sum(v[1] for v in by_x[x]) / len(by_x[x]) for x in xs]
            axes[0].plot(xs, reprojection, marker="o", label=LABELS.get(method, method))
            axes[1].plot(xs, focal, marker="o", label=LABELS.get(method, method))
        axes[0].set_ylabel("mean reprojection error against the truth (px)")
        axes[1].set_ylabel("mean relative focal error (%)")
        for ax in axes:
            ax.set_xlabel(xlabel)
            ax.set_yscale("log")
            if logx:
                ax.set_xscale("log")
            ax.grid(True, which="both", alpha=0.3)
        axes[1].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out + "/" + filename, dpi=110)
        plt.close(fig)

    plot("fig2", "image noise sigma (px)", "fig2.png", skip_zero=True)
    plot("fig2_rendered", "initial line error sigma (px), fine-tuned on rendered images", "fig2_rendered.png",
         skip_zero=True)
    plot("outliers", "fraction of wrong line correspondences", "outliers.png")
    plot("outliers_added", "fraction of wrong line correspondences (added to 30 good ones)", "outliers_added.png")
    plot("lines", "number of lines", "lines.png", logx=True)
    plot("dense", "image noise sigma (px), world noise 3 mm per px; dense polylines", "dense.png", logx=True)
    print("wrote %s/fig2.png, fig2_rendered.png, outliers.png, outliers_added.png, lines.png, dense.png" % out)


if __name__ == "__main__":
    main()
