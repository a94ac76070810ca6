#!/usr/bin/env python3
"""Re-solves a keyframe model's bundle adjustment outside dynview, from the truth or from the
model's own solution, to see how well its observations fix the intrinsics
(`docs/results/sfm.md`, "The arcs' intrinsics lie in a flat valley").

Needs numpy and scipy (`pip install scipy`). Both models are COLMAP text folders: the truth
(`target/bench/sfm/<dataset>/synth/colmap`, PINHOLE cameras) and ours
(`target/bench/sfm/<dataset>/ours/out/work/keyframes/model`, RADIAL cameras with k1 = k2 = 0,
its images' 2D points and tracks). Image names (`<camera>/<file>`) pair the two.

Unknowns: every image's pose but the first (held at its start for the gauge), the distance
from the first to the last camera centre (held by a stiff residual: the scale), each camera's
focal and principal point, every point. Example:

    python3 tools/analysis/sfm_valley.py TRUTH MODEL --start truth --nfev 800
    python3 tools/analysis/sfm_valley.py TRUTH MODEL --start model --loss cauchy
"""
import argparse

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix
from scipy.sparse.linalg import splu
from scipy.spatial.transform import Rotation

from colmap_text import read_cameras, read_images


def projection(k, R, t):
    return np.array([[k[0], 0, k[1]], [0, k[0], k[2]], [0, 0, 1]]) @ np.hstack([R, t[:, None]])


def triangulate(projections, pixels):
    rows = []
    for P, (x, y) in zip(projections, pixels):
        rows += [x * P[2] - P[0], y * P[2] - P[1]]
    X = np.linalg.svd(np.array(rows))[2][-1]
    return X[:3] / X[3]


def errors_px(projections, pixels, X):
    out = []
    for P, (x, y) in zip(projections, pixels):
        p = P @ np.append(X, 1.0)
        out.append(np.inf if p[2] <= 0 else np.hypot(p[0] / p[2] - x, p[1] / p[2] - y))
    return np.array(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("truth")
    ap.add_argument("model")
    ap.add_argument("--start", choices=["truth", "model"], default="truth")
    ap.add_argument("--loss", choices=["linear", "cauchy"], default="linear", help="cauchy: at 1 px, as dynview's")
    ap.add_argument("--max-truth-px", type=float, default=2.0, help="leave out observations farther than this from the truth's projection of their point")
    ap.add_argument("--drop-points-px", type=float, default=np.inf, help="leave out points with an observation farther than this (see --drop-by)")
    ap.add_argument("--drop-by", choices=["truth", "model"], default="truth", help="whose poses, intrinsics and points --drop-points-px measures with")
    ap.add_argument("--nfev", type=int, default=300)
    ap.add_argument("--std", action="store_true", help="the intrinsics' standard deviations at the end (Gauss-Newton covariance)")
    a = ap.parse_args()

    truth_k = read_cameras(a.truth)
    truth = {v["name"]: v for v in read_images(a.truth, False).values()}
    model_k = read_cameras(a.model)
    model_images = read_images(a.model, True)
    names = sorted(v["name"] for v in model_images.values())
    image_index = {n: i for i, n in enumerate(names)}
    cameras = sorted({n.split("/")[0] for n in names})
    image_camera = np.array([cameras.index(n.split("/")[0]) for n in names])
    by_name = {v["name"]: v for v in model_images.values()}
    P_truth = {n: projection(truth_k[truth[n]["camera"]], truth[n]["R"], truth[n]["t"]) for n in names}
    P_model = {n: projection(model_k[by_name[n]["camera"]], by_name[n]["R"], by_name[n]["t"]) for n in names}

    points, observations = [], []
    for line in open(f"{a.model}/points3D.txt"):
        if line.startswith("#"):
            continue
        f = line.split()
        track = list(map(int, f[8:]))
        obs = [(model_images[str(track[k])]["name"], model_images[str(track[k])]["points"][track[k + 1], :2]) for k in range(0, len(track), 2)]
        X = triangulate([P_truth[n] for n, _ in obs], [xy for _, xy in obs])
        near = errors_px([P_truth[n] for n, _ in obs], [xy for _, xy in obs], X) < a.max_truth_px
        obs = [o for o, keep in zip(obs, near) if keep]
        if len(obs) < 2:
            continue
        if a.drop_by == "truth":
            worst = errors_px([P_truth[n] for n, _ in obs], [xy for _, xy in obs], X).max()
        else:
            worst = errors_px([P_model[n] for n, _ in obs], [xy for _, xy in obs], np.array(list(map(float, f[1:4])))).max()
        if worst > a.drop_points_px:
            continue
        start = P_truth if a.start == "truth" else P_model
        points.append(triangulate([start[n] for n, _ in obs], [xy for _, xy in obs]))
        observations += [(image_index[n], len(points) - 1, xy[0], xy[1]) for n, xy in obs]
    obs = np.array(observations)
    n_images, n_cameras, n_points, m = len(names), len(cameras), len(points), len(obs)
    print(f"{n_points} points, {m} observations, start: {a.start}, loss: {a.loss}")

    def pose_of(R, t):
        return np.concatenate([Rotation.from_matrix(R).as_rotvec(), t])

    def intrinsics_of(source_k, source_images, c):
        name = next(n for n in names if n.startswith(cameras[c] + "/"))
        return source_k[source_images[name]["camera"]]

    truth_poses = np.array([pose_of(truth[n]["R"], truth[n]["t"]) for n in names])
    truth_intrinsics = np.array([intrinsics_of(truth_k, truth, c) for c in range(n_cameras)])
    if a.start == "truth":
        poses, intrinsics = truth_poses, truth_intrinsics
    else:
        # Our model moved onto the truth's gauge: first image's pose and the first-last distance.
        def centre(R, t):
            return -R.T @ t

        first, last = names[0], names[-1]
        Q = truth[first]["R"].T @ by_name[first]["R"]
        ct = [centre(truth[n]["R"], truth[n]["t"]) for n in (first, last)]
        ce = [centre(by_name[n]["R"], by_name[n]["t"]) for n in (first, last)]
        s = np.linalg.norm(ct[1] - ct[0]) / np.linalg.norm(ce[1] - ce[0])
        shift = ct[0] - s * Q @ ce[0]
        poses = []
        for n in names:
            R = by_name[n]["R"] @ Q.T
            poses.append(pose_of(R, -R @ (s * Q @ centre(by_name[n]["R"], by_name[n]["t"]) + shift)))
        poses = np.array(poses)
        intrinsics = np.array([intrinsics_of(model_k, by_name, c) for c in range(n_cameras)])
        points = [s * Q @ X + shift for X in points]
    fixed_pose = poses[0].copy()

    def centre_of(p):
        return -Rotation.from_rotvec(p[:3]).as_matrix().T @ p[3:]

    scale = np.linalg.norm(centre_of(poses[-1]) - centre_of(poses[0]))
    oi, op, ox, oy = obs[:, 0].astype(int), obs[:, 1].astype(int), obs[:, 2], obs[:, 3]
    n_pose = 6 * (n_images - 1)

    def unpack(x):
        all_poses = np.vstack([fixed_pose, x[:n_pose].reshape(-1, 6)])
        return all_poses, x[n_pose : n_pose + 3 * n_cameras].reshape(-1, 3), x[n_pose + 3 * n_cameras :].reshape(-1, 3)

    def residuals(x):
        p, k, X = unpack(x)
        pc = Rotation.from_rotvec(p[oi, :3]).apply(X[op]) + p[oi, 3:]
        kk = k[image_camera[oi]]
        u = kk[:, 0] * pc[:, 0] / pc[:, 2] + kk[:, 1]
        v = kk[:, 0] * pc[:, 1] / pc[:, 2] + kk[:, 2]
        gauge = np.linalg.norm(centre_of(p[-1]) - centre_of(p[0])) - scale
        return np.concatenate([u - ox, v - oy, [1e3 * gauge]])

    sparsity = lil_matrix((2 * m + 1, n_pose + 3 * n_cameras + 3 * n_points), dtype=int)
    for j, (i, p) in enumerate(zip(oi, op)):
        for row in (j, m + j):
            if i > 0:
                sparsity[row, 6 * (i - 1) : 6 * i] = 1
            c = image_camera[i]
            sparsity[row, n_pose + 3 * c : n_pose + 3 * c + 3] = 1
            sparsity[row, n_pose + 3 * n_cameras + 3 * p : n_pose + 3 * n_cameras + 3 * p + 3] = 1
    sparsity[2 * m, 6 * (n_images - 2) : n_pose] = 1
    x0 = np.concatenate([poses[1:].ravel(), intrinsics.ravel(), np.array(points).ravel()])
    r = least_squares(residuals, x0, jac_sparsity=sparsity, method="trf", loss=a.loss, x_scale="jac", max_nfev=a.nfev, ftol=1e-12, xtol=1e-12)
    print(f"cost (half the sum of the loss) {r.cost:.2f} after {r.nfev} evaluations")
    p, k, _ = unpack(r.x)
    for c in range(n_cameras):
        t = truth_intrinsics[c]
        print(f"  {cameras[c]} focal {100 * (k[c, 0] / t[0] - 1):+.2f}%  principal point {k[c, 1] - t[1]:+.2f}, {k[c, 2] - t[2]:+.2f} px from the truth")
    if a.std:
        J = r.jac.tocsc()
        lu = splu((J.T @ J).tocsc())
        variance = 2 * r.cost / (len(r.fun) - len(r.x))
        for c in range(n_cameras):
            sd = []
            for k_index in range(3):
                e = np.zeros(len(r.x))
                e[n_pose + 3 * c + k_index] = 1
                sd.append(np.sqrt(variance * lu.solve(e)[n_pose + 3 * c + k_index]))
            print(f"  {cameras[c]} std: focal {100 * sd[0] / k[c, 0]:.3f}%, cx {sd[1]:.2f} px, cy {sd[2]:.2f} px")


if __name__ == "__main__":
    main()
