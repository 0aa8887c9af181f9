#!/usr/bin/env bash
# Regenerates the Python stubs of the yamor gRPC API (proto/yamor/v1/*.proto)
# into tools/python/yamor/v1 with Debian's protoc and grpc_python_plugin.
#   tools/python/generate.sh [OUTPUT_ROOT]    # default: tools/python
# The stubs are committed; tests/python/test_stubs.py checks they are current.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="${1:-$here}"
protoc="${PROTOC:-protoc}"
plugin="${GRPC_PYTHON_PLUGIN:-/usr/bin/grpc_python_plugin}"

mkdir -p "$out/yamor/v1"
cd "$root/proto"
"$protoc" --proto_path=. \
  --python_out="$out" --pyi_out="$out" --grpc_python_out="$out" \
  --plugin=protoc-gen-grpc_python="$plugin" \
  yamor/v1/*.proto
