"""Bends the shipped bar three ways (no, uniform and non-uniform regularization) with the
Python module and draws the rest shape coloured by the diffused weights and each result
coloured by its distortion on one shared scale, as `diffreg compare` does.

    PYTHONPATH=build python3 examples/python/deform_three_ways.py -o bar-three-ways.png
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import diffreg  # noqa: E402

here = os.path.dirname(os.path.abspath(__file__))
meshes = os.path.join(here, "..", "..", "meshes")

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("-i", default=os.path.join(meshes, "bar.obj"), help="planar mesh")
parser.add_argument("--handles", default=os.path.join(meshes, "bar-bend.json"))
parser.add_argument("-o", default="bar-three-ways.png", help="output PNG")
args = parser.parse_args()

V, E = diffreg.read_mesh(args.i)
handles, targets, ranges, magnitudes, names = diffreg.read_handles(args.handles, V, E)
weights = diffreg.diffuse_weights(V, E, handles, ranges, magnitudes, t=0.01)
peak = float(weights.max())  # uniform beta = the peak weight, as in the paper's Table 1

variants = [("none", {}), ("uniform", {"beta": peak}), ("nonuniform", {"weights": weights})]
results = []
reference = None
for regularization, extra in variants:
    X, info = diffreg.deform(V, E, handles, targets, energy="arap",
                             regularization=regularization, **extra)
    if reference is None:
        reference = X
    metrics = diffreg.measure(V, E, X, energy="arap", regularization=regularization,
                              reference=reference, **extra)
    results.append((regularization, X, info, metrics))
    print(f"{regularization:10s} D_max {metrics['D_max']:.4f}  D_ave {metrics['D_ave']:.4f}  "
          f"dist {metrics['dist']:.4f}  energy {metrics['energy']:.4f}  "
          f"iterations {info['iterations']}")

scale = max(m["distortion"].max() for _, _, _, m in results)
fig, axes = plt.subplots(2, 2, figsize=(11, 6), constrained_layout=True)
all_points = np.vstack([V] + [X for _, X, _, _ in results])
lo, hi = all_points.min(axis=0), all_points.max(axis=0)
handle_ids = np.concatenate(handles)

ax = axes[0, 0]
art = ax.tripcolor(V[:, 0], V[:, 1], E, weights, shading="gouraud", cmap="viridis",
                   vmin=0, vmax=max(peak, 1e-12))
ax.plot(V[handle_ids, 0], V[handle_ids, 1], "r.", markersize=4)
ax.set_title("rest shape: diffused weights (t = 0.01)")
fig.colorbar(art, ax=ax, shrink=0.8)
for ax, (regularization, X, info, metrics) in zip(axes.flat[1:], results):
    art = ax.tripcolor(X[:, 0], X[:, 1], E, facecolors=metrics["distortion"], cmap="turbo",
                       vmin=0, vmax=scale, edgecolors="none")
    ax.plot(X[handle_ids, 0], X[handle_ids, 1], "k.", markersize=4)
    ax.set_title(f"{regularization}: D_max {metrics['D_max']:.3f}, dist {metrics['dist']:.3f}")
    fig.colorbar(art, ax=ax, shrink=0.8, label="distortion")
for ax in axes.flat:
    ax.set_aspect("equal")
    ax.set_xlim(lo[0] - 0.5, hi[0] + 0.5)
    ax.set_ylim(lo[1] - 0.5, hi[1] + 0.5)
fig.savefig(args.o, dpi=100)
print("wrote", args.o)
