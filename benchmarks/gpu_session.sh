#!/usr/bin/env bash
# One measurement step on a CUDA machine, logged to $OUT/STEP.log (and bench rows to $OUT/bench-STEP/).
#   tests  - the device-parametrised tests on cuda:0 (trace agreement, build, render, path tracer CPU = GPU)
#   build  - benchmarks/gpu_build.py: 10M-triangle lbvh/ploc builds against wp.Mesh(lbvh)
#   kernels - benchmarks/gpu_build_kernels.py: every kernel of one 10M lbvh and ploc build, summed
#   bench  - wrt bench with wrt/suites/gpu.json
#   traversal - benchmarks/gpu_traversal_ab.py: wrt layouts against wp.Mesh on 1M+ triangle scenes
#   path   - benchmarks/gpu_diagnose_path.py: CPU vs GPU path-traced pixels
#   batch  - benchmarks/batch_throughput.py: render_batch images/s
#   frames - benchmarks/multi_gpu_frames.py: a frame range on one GPU, then on all of them
#   frame  - benchmarks/frame_capture.py: the 1080p chess_set frame as a CUDA graph
# Assets: set WRT_ASSETS to a copy of the shared asset folder.
set -uo pipefail
step=${1:?usage: gpu_session.sh tests|build|kernels|bench|traversal|path|batch|frames|frame}
out=${OUT:-/tmp/out}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv > "$out/gpu.txt" 2>&1
case "$step" in
    tests) python3 -m pytest -q -p no:cacheprovider -k "cuda" tests/test_devices.py tests/test_integrators.py tests/test_robustness.py tests/test_batch.py tests/test_animation.py 2>&1 | tee "$out/tests.log" | tail -5 ;;
    traversal) python3 benchmarks/gpu_traversal_ab.py "${@:2}" 2>&1 | tee "$out/traversal.log" | tail -60 ;;
    path) python3 benchmarks/gpu_diagnose_path.py "${@:2}" 2>&1 | tee "$out/path.log" | tail -30 ;;
    batch) python3 benchmarks/batch_throughput.py "${@:2}" 2>&1 | tee "$out/batch.log" | tail -10 ;;
    frames) python3 benchmarks/multi_gpu_frames.py "${@:2}" 2>&1 | tee "$out/frames.log" | tail -10 ;;
    frame) python3 benchmarks/frame_capture.py "${@:2}" 2>&1 | tee "$out/frame.log" | tail -12 ;;
    build) python3 benchmarks/gpu_build.py "${@:2}" 2>&1 | tee "$out/build.log" | tail -40 ;;
    kernels) python3 benchmarks/gpu_build_kernels.py "${@:2}" 2>&1 | tee "$out/kernels.log" | tail -60 ;;
    bench) python3 -m wrt.cli bench gpu -o "$out/bench-gpu" -q "${@:2}" 2>&1 | tee "$out/bench.log" | tail -5
           cp "$out/bench-gpu/table.md" "$out/bench-table.md" 2>/dev/null ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
esac
