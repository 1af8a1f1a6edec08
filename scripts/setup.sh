#!/usr/bin/env bash
# Create .venv and install dresspack-gym with its test tools (torch pinned to the local CPU wheel first,
# so later packages never pull the CUDA build).
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
. .venv/bin/activate
python -m pip install -q --upgrade pip
python -c "import torch" 2>/dev/null || python -m pip install -q "torch==2.13.0"
python -m pip install -q -e ".[test]"
# the rod engine's compiled kernels, once, into numba's disk cache (else every first simulation and test worker
# compiles them: about a minute)
python -m dresspack_gym.rod.warm
