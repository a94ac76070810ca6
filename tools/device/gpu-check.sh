#!/usr/bin/env bash
# The GPU path's correctness on the lent device machine, in one call, after
# `tools/device/pack.sh --tests` here (carry [".device", ".gl"]): every dynview-gpu test (the
# sweep kernels, both of them, against the CPU; the image kernels; the plane fit; the
# consistency filter; the static mask), whole frames against the CPU's (tests/gpu_parity.rs:
# with and without the temporal terms and the plates) and `dynview render --gpu` against the
# CPU render, on the device's own
# GPU, then one timed `dynview render` of a 1920x1080 synthetic event on the GPU and the CPU.
# Logs go to $OUT. Checked here on lavapipe with `OUT=/tmp/gpu-check bash tools/device/gpu-check.sh`.
set -uo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
: "${OUT:?set OUT to the folder for the logs}"
# The binaries `pack.sh` compressed.
if [ -f .device/bin.tar.xz ]; then tar -xJf .device/bin.tar.xz -C .device; fi
# The loaders in .gl/, on the device only (it may have libvulkan but not the GL dispatch
# libraries NVIDIA's Vulkan driver needs); a machine with its own loader keeps it.
if command -v nvidia-smi >/dev/null || ! ldconfig -p | grep -q libvulkan.so.1; then
    for deb in .gl/*.deb; do dpkg -x "$deb" /; done
    ldconfig
fi
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$nvidia_icd" ] && export VK_DRIVER_FILES="$nvidia_icd"
[ -d .device/tests ] || { echo "no .device/tests: run tools/device/pack.sh --tests first" >&2; exit 2; }
# The render test runs the `dynview` it was built beside.
mkdir -p target/release
[ -x target/release/dynview ] || cp .device/dynview target/release/dynview

status=0
for test in .device/tests/*; do
    name="$(basename "$test")"
    echo "== $name"
    if ! "$test" --test-threads 1 2>&1 | tee "$OUT/test-$name.log" | grep -E "^test |adapter|result"; then
        status=1
    fi
    grep -q "test result: ok" "$OUT/test-$name.log" || status=1
done

echo "== dynview render, 1920x1080, 4 cameras, 20 frames"
event="$(mktemp -d)/event"
.device/dynview synth --out "$event" --cameras 4 --frames 20 --width 1920 --height 1080 --no-video >/dev/null || status=1
for path in gpu cpu; do
    flag=()
    [ "$path" = gpu ] && flag=(--gpu)
    start_ns=$(date +%s%N)
    .device/dynview render --scene "$event/scene" --path "$event/camera_path.json" --out "$event/$path" "${flag[@]}" 2>&1 | tail -2
    echo "$path: $(( ($(date +%s%N) - start_ns) / 1000000 )) ms for 20 frames"
done | tee "$OUT/render.log"
exit "$status"
