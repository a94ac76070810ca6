#!/usr/bin/env bash
# The GPU benchmark of issue 17 on the lent device machine, in one call, after
# `tools/device/pack.sh` here (carry [".device", ".gl"]). Writes every report to $OUT:
#   1. both sweep kernels at 1080p and 4K output (`--sweeps per-colour`, `--sweeps tiled`);
#   2. 4K under WebGPU's default limits (`--webgpu-limits`: views split into several buffers);
#   3. with SCENE (a prepared package, e.g. copied into .device/) and CAMERA_PATH (its novel
#      camera and time step), that real package at SCENE_SIZES (default 640x360,1920x1080).
# SIZES and RUNS override the sizes and timed frames (a quick check on lavapipe here:
# `OUT=/tmp/gpu SIZES=480x270 RUNS=1 bash tools/device/gpu-bench.sh`; the binaries unpacked by it
# stay in `.device/`, ignored).
set -uo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
: "${OUT:?set OUT to the folder for the reports}"
# The binaries `pack.sh` compressed.
if [ -f .device/bin.tar.xz ]; then tar -xJf .device/bin.tar.xz -C .device; fi
sizes="${SIZES:-1920x1080,3840x2160}"
runs="${RUNS:-5}"
largest="${sizes##*,}"

# The loaders in .gl/, on the device only (it may have libvulkan but not the GL dispatch
# libraries NVIDIA's Vulkan driver needs); a machine with its own loader keeps it.
if command -v nvidia-smi >/dev/null || ! ldconfig -p | grep -q libvulkan.so.1; then
    for deb in .gl/*.deb; do dpkg -x "$deb" /; done
    ldconfig
fi
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$nvidia_icd" ] && export VK_DRIVER_FILES="$nvidia_icd"
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv >"$OUT/gpu.txt"
export DYNVIEW_ROOT="$root"
eval_bin="$root/.device/dynview-eval"
[ -x "$eval_bin" ] || { echo "no $eval_bin: run tools/device/pack.sh first" >&2; exit 2; }

status=0
bench() {
    local name="$1"
    shift
    echo "== $name: dynview-eval bench $*"
    if "$eval_bin" bench "$@" 2>&1 | tee "$OUT/$name.log"; then
        cp target/bench/report.md "$OUT/$name.md"
    else
        status=1
    fi
}
bench per-colour --gpu-only --sizes "$sizes" --runs "$runs" --sweeps per-colour
bench tiled --gpu-only --sizes "$sizes" --runs "$runs" --sweeps tiled
bench webgpu-limits --gpu-only --sizes "$largest" --runs "$runs" --webgpu-limits
if [ -n "${SCENE:-}" ]; then
    bench package --gpu-only --sizes "${SCENE_SIZES:-640x360,1920x1080}" --runs "$runs" --scene "$SCENE" --camera-path "${CAMERA_PATH:?CAMERA_PATH with SCENE}"
fi
exit "$status"
