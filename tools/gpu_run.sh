#!/usr/bin/env bash
# The device machine's one command (docs/gpu.md): the GL loaders from .gl/, the Python packages its
# image lacks from .whl/ (both prepared beforehand on a machine with the registries, both
# git-ignored), then tools/gpu_results.py on the GPU's EGL driver; what comes back goes to $OUT
# (at most 8 files): the log, the environment seen, check.md, criteria.md and a tarball of
# results/<renderer>/gpu_results/ to unpack at the repository's root and commit.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT="${OUT:-/tmp/gpu_out}"
mkdir -p "$OUT"
[ -d .gl ] && [ -d .whl ] || { echo "gpu_run.sh: .gl/ and .whl/ are missing: prepare them first (docs/gpu.md)" >&2; exit 3; }

# glvnd's libEGL and libGL (the image has the NVIDIA driver but no loader), unpacked over /.
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
# The NVIDIA EGL vendor alone, so that glvnd cannot pick Mesa's llvmpipe if the image has it.
for f in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /usr/share/glvnd/egl_vendor.d/10_nvidia.json; do
    if [ -f "$f" ]; then export __EGL_VENDOR_LIBRARY_FILENAMES="$f"; break; fi
done
if [ -d /usr/local/nvidia/lib64 ]; then export LD_LIBRARY_PATH="/usr/local/nvidia/lib64:${LD_LIBRARY_PATH:-}"; fi
export GLCONTEXT_LINUX_LIBEGL=libEGL.so.1 GLCONTEXT_LINUX_LIBGL=libGL.so.1

python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 3
export PYTHONPATH=/tmp/site PYTHONUNBUFFERED=1
{
    nvidia-smi -L
    python3 --version
    echo "__EGL_VENDOR_LIBRARY_FILENAMES=${__EGL_VENDOR_LIBRARY_FILENAMES:-}"
    ldconfig -p | grep -E 'libEGL|libGL\.so|libGLX|nvidia'
} >"$OUT/environment.txt" 2>&1

# 9 minutes at most: the device's commands have 10, and the tarball is made after.
timeout 540 python3 tools/gpu_results.py --require-gpu "$@" 2>&1 | tee "$OUT/log.txt"
status=${PIPESTATUS[0]}
folders=$(ls -d results/*/gpu_results 2>/dev/null | grep -v '^results/llvmpipe/')
if [ -n "$folders" ]; then
    tar -czf "$OUT/gpu_results.tar.gz" $folders
    for folder in $folders; do cp "$folder/check.md" "$folder/criteria.md" "$OUT/" 2>/dev/null; done
fi
exit "$status"
