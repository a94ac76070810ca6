#!/usr/bin/env python3
"""Rotation and intrinsics errors of a `dynview prep` poses.json against a COLMAP text model
of the truth (`docs/results/sfm.md`): every posed frame's orientation after one rotation that
best aligns them all (no scale or translation: orientations only), and each camera's focal
and principal point. Needs numpy.

    python3 tools/analysis/pose_errors.py target/eval/arc8x90/event/colmap OUT/poses.json
"""
import json
import sys

import numpy as np

from colmap_text import read_cameras, read_images


def main():
    truth_dir, poses_path = sys.argv[1], sys.argv[2]
    cameras = read_cameras(truth_dir)
    rotations, camera_of = {}, {}
    for image in read_images(truth_dir, False).values():
        camera, file = image["name"].split("/")
        rotations[(camera, file.split(".")[0])] = image["R"]
        camera_of[camera] = image["camera"]
    estimate = json.load(open(poses_path))
    pairs = []
    for camera in estimate["cameras"]:
        for frame in camera["frames"]:
            key = (camera["name"], frame["file"].split(".")[0])
            if frame["camera_from_world"] and key in rotations:
                pairs.append((np.array(frame["camera_from_world"]["rotation"]), rotations[key]))
    U, _, Vt = np.linalg.svd(sum(e.T @ t for e, t in pairs))
    align = U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt
    errors = [np.degrees(np.arccos(np.clip((np.trace(e @ align @ t.T) - 1) / 2, -1, 1))) for e, t in pairs]
    print(f"{len(errors)} frames: rotation error median {np.median(errors):.3f} deg, max {np.max(errors):.3f}")
    for camera in estimate["cameras"]:
        fx, cx, cy = cameras[camera_of[camera["name"]]]
        k = camera["intrinsics"]
        # COLMAP's pixel centres are at +0.5, dynview's at 0.
        print(f"  {camera['name']}: focal {100 * (k['fx'] / fx - 1):+.2f}%, principal point {k['cx'] - (cx - 0.5):+.1f}, {k['cy'] - (cy - 0.5):+.1f} px from the truth")


if __name__ == "__main__":
    main()
