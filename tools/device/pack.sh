#!/usr/bin/env bash
# Packs what the GPU benchmark needs on the lent device machine (no Rust there): a stripped
# release `dynview-eval` in `.device/` and the Vulkan loader's Debian packages in `.gl/`, both
# ignored by git (`.git/info/exclude`) and carried by the device call. Run from anywhere:
#   tools/device/pack.sh
# then on the device, in one call (carry [".device", ".gl"], timeout_s 540):
#   bash tools/device/gpu-bench.sh
# With `--tests` it also packs `dynview` and the GPU tests' binaries (`.device/tests/`) for
#   bash tools/device/gpu-check.sh
# The binaries travel compressed (`.device/bin.tar.xz`, about 13 MB against 57): the working
# tree a device call carries is at most 64 MiB, a prepared package to time included. Both
# scripts unpack it.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
mkdir -p "$(git rev-parse --git-dir)/info"
exclude="$(git rev-parse --git-dir)/info/exclude"
for path in /.device/ /.gl/; do
    grep -qxF "$path" "$exclude" 2>/dev/null || echo "$path" >>"$exclude"
done

echo "building dynview-eval (release)"
cargo build --release -p dynview-eval
mkdir -p .device
strip -o .device/dynview-eval target/release/dynview-eval
echo "packed .device/dynview-eval ($(du -h .device/dynview-eval | cut -f1))"

if [ "${1:-}" = --tests ]; then
    echo "building dynview and the GPU tests (release)"
    # Without `prep`: the device has no OpenCV, and the GPU checks need synth and render only.
    cargo build --release -p dynview-cli --no-default-features
    strip -o .device/dynview target/release/dynview
    cargo build --release -p dynview-cli
    rm -rf .device/tests
    mkdir -p .device/tests
    { cargo test --release -p dynview-gpu --no-run --message-format=json
      cargo test --release -p dynview-cli --test render --no-run --message-format=json
      cargo test --release -p dynview-tests --test gpu_parity --no-run --message-format=json; } |
        grep -o '"executable":"[^"]*/deps/[^"]*"' | cut -d'"' -f4 |
        while read -r exe; do
            name="$(basename "$exe")"
            strip -o ".device/tests/${name%-*}" "$exe"
        done
    echo "packed .device/tests/ ($(ls .device/tests | tr '\n' ' '))"
fi

echo "compressing the binaries into .device/bin.tar.xz"
(cd .device && tar -cf - dynview-eval $( [ -d tests ] && echo dynview tests ) | xz -T0 -6 >bin.tar.xz.partial && mv bin.tar.xz.partial bin.tar.xz)
rm -rf .device/dynview-eval .device/dynview .device/tests

# The Vulkan loader and the GL dispatch libraries: NVIDIA's Vulkan driver (libGLX_nvidia.so.0)
# does not load without libglvnd's.
if ! ls .gl/libvulkan1_*.deb .gl/libglvnd0_*.deb >/dev/null 2>&1; then
    echo "downloading the Vulkan and GL loaders (amd64) into .gl/"
    mkdir -p .gl /tmp/dynview-amd64/partial
    apt_options=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/dynview-amd64)
    apt-get "${apt_options[@]}" update -qq
    (cd .gl && apt-get "${apt_options[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
fi
echo "packed .gl/ ($(du -sh .gl | cut -f1)): carry [\".device\", \".gl\"] and run: bash tools/device/gpu-bench.sh"
