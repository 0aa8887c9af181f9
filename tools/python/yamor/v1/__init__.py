"""Generated protobuf and gRPC stubs of the yamor.v1 API (tools/python/generate.sh)."""
