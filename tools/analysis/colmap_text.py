"""Reading COLMAP text models (cameras.txt, images.txt) for the analysis scripts. Needs numpy."""
import numpy as np


def quaternion_matrix(w, x, y, z):
    """The rotation matrix of a unit quaternion (COLMAP's order: w first)."""
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def read_cameras(folder):
    """camera id -> (focal, cx, cy), COLMAP's pixel convention (centres at +0.5)."""
    cameras = {}
    for line in open(f"{folder}/cameras.txt"):
        if line.startswith("#") or not line.strip():
            continue
        f = line.split()
        v = list(map(float, f[4:]))
        cameras[f[0]] = (v[0], v[1], v[2]) if f[1] in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL") else (v[0], v[2], v[3])
    return cameras


def read_images(folder, with_points):
    """image id -> dict(name, R, t, camera, points: (N, 3) x, y, point id, or None)."""
    lines = [l for l in open(f"{folder}/images.txt") if not l.startswith("#")]
    images, i = {}, 0
    while i < len(lines):
        f = lines[i].split()
        if len(f) >= 10 and f[0].isdigit():
            points = np.array(list(map(float, lines[i + 1].split()))).reshape(-1, 3) if with_points else None
            images[f[0]] = dict(name=f[9], R=quaternion_matrix(*map(float, f[1:5])), t=np.array(list(map(float, f[5:8]))), camera=f[8], points=points)
            i += 2
        else:
            i += 1
    return images
