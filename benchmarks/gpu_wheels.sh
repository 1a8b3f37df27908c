#!/usr/bin/env bash
# Wheels for a GPU machine that has Python 3.12 and torch but none of swimrl's other needs
# (docs/training.md, "Training on a GPU"): downloads them into .whl/ (git-ignored), the
# versions pinned to those of the local environment (.venv). benchmarks/gpu_session.sh
# installs them there with --no-index.
set -euo pipefail
cd "$(dirname "$0")/.."
PIP=${PIP:-.venv/bin/pip}
names="torchrl tensordict hoptorch pyvers orjson importlib_metadata lazy-importer hydra-core
       omegaconf antlr4-python3-runtime zarr numcodecs donfig google-crc32c"
mkdir -p .whl
for name in $names; do
  version=$($PIP show "$name" | sed -n 's/^Version: //p')
  if [ "$name" = antlr4-python3-runtime ]; then  # pure Python, published as sdist only
    $PIP wheel -q --no-deps -w .whl "$name==$version"; continue
  fi
  $PIP download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
      --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
      --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
      --platform manylinux1_x86_64 -d .whl "$name==$version"
done
ls .whl
