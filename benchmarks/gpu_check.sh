#!/usr/bin/env bash
# GPU check: the same kernels on a CUDA machine, in at most ~5 minutes.
#
#   bash benchmarks/gpu_check.sh --pack   # on a machine with PyPI: pack the wheels it needs
#   bash benchmarks/gpu_check.sh          # on the CUDA machine (Python 3.12, numpy, scipy)
#
# --pack downloads the wheels named in WHEELS for CPython 3.12 on manylinux x86_64, installs
# them into a folder and packs that as .gpu/site.tar.xz (xz packs Taichi's library to about
# two thirds of its wheel). Without --pack the script unpacks .gpu/site.tar.xz if it is there,
# then prints: the machine and GPU; bench_step's vertex-steps per second on the CPU and on
# CUDA at several sheet sizes; the hanging-sheet scene run to the stop rule on both, with the
# largest difference between their final positions; and the T-shirt drape at 3 cm on CUDA
# (only where Open3D imports: the drape's placement and contact metrics use it, and its
# wheel is far larger than what a machine without PyPI can be sent).
set -uo pipefail
cd "$(dirname "$0")/.."
WHEELS="taichi==1.7.4 triangle==20250106 trimesh==4.5.3 dill==0.3.9 jsonschema==4.23.0 \
jsonschema-specifications==2024.10.1 referencing==0.35.1 rpds-py==0.22.3"
SITE=/tmp/gpu_check_site

if [ "${1:-}" = "--pack" ]; then
  rm -rf .gpu/wheels "$SITE" && mkdir -p .gpu/wheels
  # shellcheck disable=SC2086
  python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
    --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
    --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 -d .gpu/wheels $WHEELS
  python3 -m pip install -q --no-deps --no-compile --target "$SITE" .gpu/wheels/*.whl \
    --python-version 3.12 --only-binary=:all: --implementation cp
  tar -C "$SITE" -cJf .gpu/site.tar.xz . && rm -rf .gpu/wheels
  ls -la .gpu
  exit 0
fi

if [ -f .gpu/site.tar.xz ]; then
  mkdir -p "$SITE" && tar -C "$SITE" -xJf .gpu/site.tar.xz
  export PYTHONPATH="$SITE:$PWD"
else
  export PYTHONPATH="$PWD"
fi
export PYTHONUNBUFFERED=1
ARCH=${GPU_CHECK_ARCH:-cuda}
echo "== machine"
uname -srm; nproc; python3 --version
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null \
  || echo "no nvidia-smi"
python3 -c "import taichi, numpy; print('taichi', taichi.__version__, 'numpy', numpy.__version__)"

echo "== bench_step (vertex-steps/s), cpu then $ARCH"
timeout 100 python3 benchmarks/bench_step.py --arch cpu --sizes 4000 16000 --seconds 2
timeout 100 python3 benchmarks/bench_step.py --arch "$ARCH" --sizes 4000 16000 64000 256000 \
  --seconds 2

echo "== hanging sheet to the stop rule, cpu against $ARCH"
timeout 150 python3 - "$ARCH" <<'PY'
import sys
import time

import numpy as np

from sandbox import runtime
from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.scene.spec import load_scene

finals = []
for arch in ("cpu", sys.argv[1]):
    runtime.init(arch)
    t0 = time.perf_counter()
    res = run_scene(build_scene(load_scene("sandbox/scenes/hanging_sheet.toml")), progress=False)
    m = res.metrics
    finals.append(res.positions)
    print(f"{arch}: {m['vertex_count']} vertices, {m['steps']} steps, converged {m['converged']}"
          f" at {m['sim_time_s']:.2f} s simulated, {time.perf_counter() - t0:.1f} s wall "
          f"({m['vertex_steps_per_s'] / 1e6:.1f} M vertex-steps/s)")
a, b = finals
print(f"largest difference between the final positions: {np.abs(a - b).max() * 1e3:.3g} mm")
PY

echo "== t-shirt drape at 3 cm on $ARCH"
if python3 -c "import open3d" 2>/dev/null; then
  timeout 200 python3 -m sandbox drape t-shirt --edge-cm 3 --arch "$ARCH" --no-render \
    --no-meshes --out /tmp/gpu_check_tshirt
else
  echo "skipped: open3d does not import here"
fi
